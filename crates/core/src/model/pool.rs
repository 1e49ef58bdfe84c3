//! The pool a run was recorded in and the geometry the left-out effects read from it: the
//! distance to the nearest side wall and the length of tether in the water. Written once, for
//! the diagnosis, the report and the twin.

use serde::{Deserialize, Serialize};

/// The pool: x along its length, y across, z down from the surface; the origin in a corner.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pool {
    pub length_m: f64,
    pub width_m: f64,
    pub depth_m: f64,
}

impl Pool {
    /// Distance from (x, y) in the pool frame to the nearest side wall, m (negative outside).
    pub fn wall_distance(&self, x: f64, y: f64) -> f64 {
        [x, self.length_m - x, y, self.width_m - y]
            .into_iter()
            .fold(f64::INFINITY, f64::min)
    }
}

/// Straight-line distance from the tether's anchor to the vehicle, m (the tether in the water
/// without its slack).
pub fn tether_length(anchor: [f64; 3], pos: [f64; 3]) -> f64 {
    ((pos[0] - anchor[0]).powi(2) + (pos[1] - anchor[1]).powi(2) + (pos[2] - anchor[2]).powi(2))
        .sqrt()
}
