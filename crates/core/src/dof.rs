//! Degrees of freedom, their symbols and units (docs/formats.md conventions, SNAME notation).

use serde::{Deserialize, Serialize};
use std::fmt;

/// One of the six rigid-body degrees of freedom, in body-frame order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Dof {
    Surge,
    Sway,
    Heave,
    Roll,
    Pitch,
    Yaw,
}

impl Dof {
    pub const ALL: [Dof; 6] = [
        Dof::Surge,
        Dof::Sway,
        Dof::Heave,
        Dof::Roll,
        Dof::Pitch,
        Dof::Yaw,
    ];

    /// Position in the 6-vectors `nu = [u v w p q r]` and `tau = [X Y Z K M N]`.
    pub fn index(self) -> usize {
        self as usize
    }

    pub fn name(self) -> &'static str {
        ["surge", "sway", "heave", "roll", "pitch", "yaw"][self.index()]
    }

    pub fn from_name(name: &str) -> Option<Dof> {
        Dof::ALL.into_iter().find(|d| d.name() == name)
    }

    /// Velocity symbol: u v w p q r.
    pub fn velocity(self) -> &'static str {
        ["u", "v", "w", "p", "q", "r"][self.index()]
    }

    /// Generalised force symbol: X Y Z K M N.
    pub fn force(self) -> &'static str {
        ["X", "Y", "Z", "K", "M", "N"][self.index()]
    }

    pub fn is_angular(self) -> bool {
        self.index() >= 3
    }

    /// Body axis letter used by STAR-CCM+ monitors: X for surge and roll, Y for sway and pitch, Z for heave and yaw.
    pub fn axis(self) -> char {
        ['X', 'Y', 'Z'][self.index() % 3]
    }

    pub fn velocity_unit(self) -> &'static str {
        if self.is_angular() { "rad/s" } else { "m/s" }
    }

    pub fn force_unit(self) -> &'static str {
        if self.is_angular() { "N m" } else { "N" }
    }

    /// The DOF a body-axis monitor refers to: linear (force, velocity) or angular (moment, rate).
    pub fn from_axis(axis: char, angular: bool) -> Option<Dof> {
        let i = "XYZ".find(axis.to_ascii_uppercase())?;
        Some(Dof::ALL[i + if angular { 3 } else { 0 }])
    }
}

impl fmt::Display for Dof {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_round_trip() {
        for d in Dof::ALL {
            assert_eq!(Dof::from_axis(d.axis(), d.is_angular()), Some(d));
            assert_eq!(Dof::from_name(d.name()), Some(d));
        }
    }
}
