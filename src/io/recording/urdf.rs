//! URDF: each joint's `<origin xyz rpy>` is `T_parent_child` between its links, so the joints
//! make a transform [`Tree`] like `/tf_static`'s. [`Urdf::with_origins`] writes corrected
//! origins back into the loaded text, touching nothing else.

use std::ops::Range;

use super::tf::{Transform, Tree};
use crate::se3::{Pose, pose_from_xyz_rpy, xyz_rpy};

/// A joint between two links.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    pub name: String,
    pub parent: String,
    pub child: String,
    /// `T_parent_child` (identity when the joint has no `<origin>`).
    pub origin: Pose,
    /// Byte range of the `<origin>` element, or where one is inserted (just before `</joint>`).
    range: Range<usize>,
    has_origin: bool,
}

/// A parsed URDF and its text.
#[derive(Clone, Debug)]
pub struct Urdf {
    pub text: String,
    pub joints: Vec<Joint>,
}

fn numbers(value: Option<&str>, what: &str) -> Result<[f64; 3], String> {
    let Some(value) = value else { return Ok([0.0; 3]) };
    let v: Vec<f64> = value
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()
        .map_err(|_| format!("{what}=\"{value}\" is not three numbers"))?;
    match v.as_slice() {
        [a, b, c] if v.iter().all(|x| x.is_finite()) => Ok([*a, *b, *c]),
        _ => Err(format!("{what}=\"{value}\" is not three finite numbers")),
    }
}

impl Urdf {
    /// Parses `text`; errors name the joint and what is wrong.
    pub fn parse(text: &str) -> Result<Self, String> {
        let doc = roxmltree::Document::parse(text).map_err(|e| e.to_string())?;
        let mut joints = Vec::new();
        for j in doc.descendants().filter(|n| {
            n.has_tag_name("joint") && n.parent().is_some_and(|p| p.has_tag_name("robot"))
        }) {
            let name = j.attribute("name").unwrap_or("").to_string();
            let link = |tag: &str| {
                j.children()
                    .find(|c| c.has_tag_name(tag))
                    .and_then(|c| c.attribute("link"))
                    .map(str::to_string)
                    .ok_or_else(|| format!("joint '{name}' has no <{tag} link=...>"))
            };
            let (parent, child) = (link("parent")?, link("child")?);
            let origin = j.children().find(|c| c.has_tag_name("origin"));
            let (pose, range, has_origin) = match origin {
                Some(o) => {
                    let xyz = numbers(o.attribute("xyz"), "xyz")
                        .map_err(|e| format!("joint '{name}': {e}"))?;
                    let rpy = numbers(o.attribute("rpy"), "rpy")
                        .map_err(|e| format!("joint '{name}': {e}"))?;
                    (pose_from_xyz_rpy(xyz, rpy), o.range(), true)
                }
                None => {
                    let end = j.range().end;
                    let at = if text[..end].ends_with("</joint>") {
                        end - "</joint>".len()
                    } else {
                        end
                    };
                    (Pose::identity(), at..at, false)
                }
            };
            joints.push(Joint { name, parent, child, origin: pose, range, has_origin });
        }
        Ok(Self { text: text.to_string(), joints })
    }

    /// The joints as a transform tree.
    pub fn tree(&self) -> Tree {
        Tree::new(self.joints.iter().map(|j| Transform {
            parent: j.parent.clone(),
            child: j.child.clone(),
            pose: j.origin,
            stamp_ns: 0,
        }))
    }

    /// The text with the joint above each `(link, T_base_link)` given a new origin so the link
    /// resolves to that pose (its parent's pose kept). Errors name a link no joint leads to.
    pub fn with_origins(&self, base: &str, poses: &[(String, Pose)]) -> Result<String, String> {
        let tree = self.tree();
        let mut edits: Vec<(Range<usize>, String)> = Vec::new();
        for (link, pose) in poses {
            let joint = self
                .joints
                .iter()
                .find(|j| &j.child == link)
                .ok_or_else(|| format!("no joint has child link '{link}'"))?;
            let parent = if joint.parent == base {
                Pose::identity()
            } else {
                tree.resolve(base, &joint.parent).map_err(|e| e.to_string())?
            };
            let (xyz, rpy) = xyz_rpy(&(parent.inverse() * pose));
            let fmt = |v: [f64; 3]| v.map(|x| format!("{x}")).join(" ");
            let mut element = format!("<origin xyz=\"{}\" rpy=\"{}\"/>", fmt(xyz), fmt(rpy));
            if !joint.has_origin {
                element = format!("  {element}\n  ");
            }
            edits.push((joint.range.clone(), element));
        }
        edits.sort_by_key(|(r, _)| std::cmp::Reverse(r.start));
        let mut text = self.text.clone();
        for (range, element) in edits {
            text.replace_range(range, &element);
        }
        Ok(text)
    }
}
