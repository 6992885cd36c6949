//! A simulated LiDAR: a spinning one ([`Spinning`], organized rows of channels) or a solid-state
//! rosette scanner ([`Rosette`], one unorganized row). Presets hold this, so a rig mixes both.

use rand::Rng;

use super::rosette::Rosette;
use super::scene::Scene;
use super::spinning::Spinning;
use crate::cloud::Cloud;
use crate::se3::Pose;

/// What a sensor of the twin scans like.
#[derive(Clone, Debug, PartialEq)]
pub enum Lidar {
    Spinning(Spinning),
    Rosette(Rosette),
}

impl Lidar {
    /// A spinning LiDAR with `channels` beams spread evenly over `fov_min..=fov_max` (rad),
    /// `horizontal_steps` columns over 360 deg, `max_range` (m) and range noise `noise` (m):
    /// [`Spinning::uniform`].
    pub fn uniform(
        channels: usize,
        fov_min: f64,
        fov_max: f64,
        horizontal_steps: usize,
        max_range: f64,
        noise: f64,
    ) -> Self {
        Self::Spinning(Spinning::uniform(
            channels,
            fov_min,
            fov_max,
            horizontal_steps,
            max_range,
            noise,
        ))
    }

    /// Columns of a scan (a rosette's shots per frame).
    pub fn width(&self) -> usize {
        match self {
            Self::Spinning(s) => s.width(),
            Self::Rosette(r) => r.points,
        }
    }

    /// Rows of a scan (channels; one for a rosette).
    pub fn height(&self) -> usize {
        match self {
            Self::Spinning(s) => s.height(),
            Self::Rosette(_) => 1,
        }
    }

    /// Returns farther than this are misses (m).
    pub fn max_range(&self) -> f64 {
        match self {
            Self::Spinning(s) => s.max_range,
            Self::Rosette(r) => r.max_range,
        }
    }

    /// The standard deviation of the range noise (m), to read or set.
    pub fn range_noise_mut(&mut self) -> &mut f64 {
        match self {
            Self::Spinning(s) => &mut s.range_noise,
            Self::Rosette(r) => &mut r.range_noise,
        }
    }

    /// Whether coordinates are rounded to IEEE binary16, to read or set.
    pub fn float16_mut(&mut self) -> &mut bool {
        match self {
            Self::Spinning(s) => &mut s.float16,
            Self::Rosette(r) => &mut r.float16,
        }
    }

    /// The spinning model, if it is one.
    pub fn spinning(&self) -> Option<&Spinning> {
        match self {
            Self::Spinning(s) => Some(s),
            Self::Rosette(_) => None,
        }
    }

    /// The spinning model, if it is one, to change.
    pub fn spinning_mut(&mut self) -> Option<&mut Spinning> {
        match self {
            Self::Spinning(s) => Some(s),
            Self::Rosette(_) => None,
        }
    }

    /// Frame `frame` (0-based) from pose `t_world_sensor`: `width() * height()` points in the
    /// SENSOR frame (m), misses as exact zeros, fresh noise from `rng`. A spinning LiDAR's
    /// every revolution is alike; a rosette's pattern goes on from the previous frame's.
    pub fn scan(
        &self,
        scene: &Scene,
        t_world_sensor: &Pose,
        frame: usize,
        rng: &mut impl Rng,
    ) -> Cloud {
        match self {
            Self::Spinning(s) => s.scan(scene, t_world_sensor, rng),
            Self::Rosette(r) => r.scan(scene, t_world_sensor, frame, rng),
        }
    }
}
