//! `tf2_msgs/TFMessage` and the transform tree: each `TransformStamped` is `T_parent_child`
//! (it maps points from `child_frame_id` into `header.frame_id`). [`Tree::resolve`] chains
//! them into `T_base_frame` for any frame connected to the base. URDF joints fill the same
//! tree (`urdf`).

use nalgebra::{Quaternion, Translation3, UnitQuaternion};

use super::index::Encoding;
use super::wire::Wire;
use crate::se3::Pose;

/// One edge of the tree: `pose` = `T_parent_child`.
#[derive(Clone, Debug, PartialEq)]
pub struct Transform {
    pub parent: String,
    pub child: String,
    pub pose: Pose,
    pub stamp_ns: i64,
}

/// Decodes a TFMessage.
pub fn decode(data: &[u8], encoding: Encoding) -> Result<Vec<Transform>, String> {
    let mut w = Wire::new(data, encoding)?;
    let n = w.u32("transforms length")? as usize;
    let mut out = Vec::with_capacity(n.min(1024));
    for _ in 0..n {
        let (stamp_ns, parent) = w.header()?;
        let child = w.string("child_frame_id")?;
        let t = [w.f64("translation")?, w.f64("translation")?, w.f64("translation")?];
        let [qx, qy, qz, qw] =
            [w.f64("rotation")?, w.f64("rotation")?, w.f64("rotation")?, w.f64("rotation")?];
        let q = Quaternion::new(qw, qx, qy, qz);
        if !(t.iter().all(|v| v.is_finite()) && q.norm() > 1e-9 && q.norm().is_finite()) {
            return Err(format!(
                "transform {parent} -> {child} is not finite or has a zero quaternion"
            ));
        }
        let pose = Pose::from_parts(
            Translation3::new(t[0], t[1], t[2]),
            UnitQuaternion::from_quaternion(q),
        );
        out.push(Transform { parent, child, pose, stamp_ns });
    }
    Ok(out)
}

/// Why a frame's pose could not be resolved.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TreeError {
    /// The frame is in no transform.
    UnknownFrame(String),
    /// The frame is in a different tree from the base.
    NotConnected { frame: String, base: String },
    /// No base was given and the tree has no single root.
    NoRoot(Vec<String>),
}

impl std::fmt::Display for TreeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TreeError::UnknownFrame(frame) => write!(f, "frame '{frame}' is in no transform"),
            TreeError::NotConnected { frame, base } => {
                write!(f, "frame '{frame}' is not connected to '{base}'")
            }
            TreeError::NoRoot(roots) => {
                write!(f, "the transforms have several roots: {}", roots.join(", "))
            }
        }
    }
}

impl std::error::Error for TreeError {}

/// A transform tree: each child's latest parent edge.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Tree {
    /// In first-seen order; a later edge for the same child replaces the earlier.
    pub edges: Vec<Transform>,
}

impl Tree {
    pub fn new(transforms: impl IntoIterator<Item = Transform>) -> Self {
        let mut tree = Self::default();
        for t in transforms {
            match tree.edges.iter_mut().find(|e| e.child == t.child) {
                Some(e) => *e = t,
                None => tree.edges.push(t),
            }
        }
        tree
    }

    fn parent_of(&self, frame: &str) -> Option<&Transform> {
        self.edges.iter().find(|e| e.child == frame)
    }

    /// Frames that are a parent but no one's child, in first-seen order.
    pub fn roots(&self) -> Vec<String> {
        let mut roots: Vec<String> = Vec::new();
        for e in &self.edges {
            if self.parent_of(&e.parent).is_none() && !roots.contains(&e.parent) {
                roots.push(e.parent.clone());
            }
        }
        roots
    }

    pub fn contains(&self, frame: &str) -> bool {
        self.edges.iter().any(|e| e.child == frame || e.parent == frame)
    }

    /// The base frame to use: `wanted` when the tree has it, else the single root.
    pub fn base(&self, wanted: &str) -> Result<String, TreeError> {
        if self.contains(wanted) {
            return Ok(wanted.to_string());
        }
        match self.roots().as_slice() {
            [root] => Ok(root.clone()),
            roots => Err(TreeError::NoRoot(roots.to_vec())),
        }
    }

    /// `T_root_frame` and the root, following parents (a cycle ends the walk).
    fn to_root(&self, frame: &str) -> (Pose, String) {
        let (mut pose, mut at) = (Pose::identity(), frame.to_string());
        for _ in 0..=self.edges.len() {
            let Some(e) = self.parent_of(&at) else { break };
            pose = e.pose * pose;
            at = e.parent.clone();
        }
        (pose, at)
    }

    /// `T_base_frame`: maps points from `frame` into `base`.
    pub fn resolve(&self, base: &str, frame: &str) -> Result<Pose, TreeError> {
        for f in [frame, base] {
            if !self.contains(f) {
                return Err(TreeError::UnknownFrame(f.to_string()));
            }
        }
        let (root_frame, r1) = self.to_root(frame);
        let (root_base, r2) = self.to_root(base);
        if r1 != r2 {
            return Err(TreeError::NotConnected { frame: frame.into(), base: base.into() });
        }
        Ok(root_base.inverse() * root_frame)
    }

    /// Each frame's depth below its root (roots are 0), for printing the tree.
    pub fn depth(&self, frame: &str) -> usize {
        let mut at = frame;
        let mut depth = 0;
        while let Some(e) = self.parent_of(at) {
            depth += 1;
            at = &e.parent;
            if depth > self.edges.len() {
                break;
            }
        }
        depth
    }
}
