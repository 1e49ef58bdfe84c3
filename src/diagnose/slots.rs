//! The DOFs a diagnosis compares a model in ([`Slots`]) and the recorded channel of each.

use crate::core::dof::Dof;
use crate::core::model::Plant;

/// How many DOFs a diagnosis can compare a model in: all six.
pub const SLOTS: usize = 6;

/// The DOF of each slot: slot j is the DOF of index j in nu (surge, sway, heave, roll, pitch,
/// yaw).
pub const ORDER: [Dof; SLOTS] = Dof::ALL;

/// Which DOFs a diagnosis compares the model in: one slot per DOF, slot j the DOF of index j
/// in nu ([`ORDER`]), so the per-slot arrays are body vectors. A slot the model leaves out is held at rest and never scored: a four-DOF pool model is
/// compared in surge, sway, heave and yaw; a six-DOF one in all six, its roll and pitch rates
/// against the fused ones; one in roll, pitch and yaw alone (a vehicle whose logs have no DVL)
/// in those.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Slots {
    pub active: [bool; SLOTS],
}

impl Slots {
    /// Surge, sway, heave and yaw, all modelled.
    pub const POOL: Slots = Slots {
        active: [true, true, true, false, false, true],
    };

    /// The slots for a plant's active DOFs; `None` when it moves in none of them.
    pub fn of(plant: &Plant) -> Option<Slots> {
        let active = ORDER.map(|d| plant.active[d.index()]);
        (active.iter().any(|a| *a)).then_some(Slots { active })
    }

    /// The DOF of slot `j`.
    pub fn dof(&self, j: usize) -> Dof {
        ORDER[j]
    }

    /// The indices into nu of the slots.
    pub fn nu_all(&self) -> [usize; SLOTS] {
        std::array::from_fn(|j| j)
    }

    /// The slot of DOF `d`, when it is one the model moves in.
    pub fn slot(&self, d: Dof) -> Option<usize> {
        (0..SLOTS).find(|&j| self.dof(j) == d && self.active[j])
    }

    /// The slots the model moves in.
    pub fn on(&self) -> impl Iterator<Item = usize> + '_ {
        (0..SLOTS).filter(|&j| self.active[j])
    }

    /// The slots the model moves in whose DOF is among `dofs`.
    pub fn among(&self, dofs: &[Dof]) -> Vec<usize> {
        self.on().filter(|&j| dofs.contains(&self.dof(j))).collect()
    }

    /// The DOFs the model moves in that run `f` has no fused velocity for.
    pub fn missing(&self, f: &crate::pool::fusion::Fused) -> Vec<Dof> {
        self.on()
            .map(|j| self.dof(j))
            .filter(|&d| slot_channel(f, d).is_none())
            .collect()
    }
}

/// The velocity a diagnosis compares DOF `d` with, its standard deviation and the sensor's
/// share of it ([`super::Run::noise_share`]): the tracked velocities for surge, sway, heave and yaw,
/// the fused body rates for roll and pitch.
pub(super) fn slot_channel(
    f: &crate::pool::fusion::Fused,
    d: Dof,
) -> Option<(&[f64], &[f64], f64)> {
    // The velocities that keep the motion (a navigation log's smoothed under its sensor's
    // own noise): the diagnosis compares simulations with them, and a flattened motion
    // hides what the model lacks.
    let rate = |i: usize| {
        let rp = &f.roll_pitch;
        let (v, s) = (rp.rate[i].as_deref()?, rp.rate_std[i].as_deref()?);
        (v.len() == f.t.len() && s.len() == f.t.len()).then_some((v, s, 1.0))
    };
    match d {
        Dof::Surge => f.tracking(0),
        Dof::Sway => f.tracking(1),
        Dof::Heave => f.tracking(2),
        Dof::Yaw => f.tracking(3),
        Dof::Roll => rate(0),
        Dof::Pitch => rate(1),
    }
}
