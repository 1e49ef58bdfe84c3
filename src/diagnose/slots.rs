//! The DOFs a diagnosis compares a model in ([`Slots`]) and the recorded channel of each.

use super::DOFS;
use crate::core::dof::Dof;
use crate::core::model::{Plant, Vec6};

/// The four DOFs a diagnosis compares the model in, in the order of its per-DOF arrays, and
/// which of them the model moves in. A model in surge or sway is compared in surge, sway, heave
/// and yaw (a six-DOF one too: its roll and pitch are simulated, not scored); one in roll or
/// pitch without them (a vehicle whose logs have no DVL) in heave, roll, pitch and yaw. A slot
/// the model leaves out is held at rest and never scored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Slots {
    pub dofs: [Dof; 4],
    pub active: [bool; 4],
    /// Whether the model also moves in roll and pitch beside surge or sway (a six-DOF model):
    /// those are simulated from the run's command, rates and attitude ([`Tilt`]), not scored.
    pub tilts: bool,
}

impl Slots {
    /// Surge, sway, heave and yaw, all modelled.
    pub const POOL: Slots = Slots {
        dofs: DOFS,
        active: [true; 4],
        tilts: false,
    };

    /// The slots for a plant's active DOFs; `None` when it moves in none of them.
    pub fn of(plant: &Plant) -> Option<Slots> {
        let on = |d: Dof| plant.active[d.index()];
        let rotation = !on(Dof::Surge) && !on(Dof::Sway) && (on(Dof::Roll) || on(Dof::Pitch));
        let dofs = match rotation {
            true => [Dof::Heave, Dof::Roll, Dof::Pitch, Dof::Yaw],
            false => DOFS,
        };
        let active = dofs.map(on);
        let tilts = !rotation && (on(Dof::Roll) || on(Dof::Pitch));
        (active.iter().any(|a| *a)).then_some(Slots {
            dofs,
            active,
            tilts,
        })
    }

    /// Index into nu of slot `j`.
    pub fn nu(&self, j: usize) -> usize {
        self.dofs[j].index()
    }

    /// The indices into nu of the four slots.
    pub fn nu_all(&self) -> [usize; 4] {
        self.dofs.map(|d| d.index())
    }

    /// The slot of DOF `d`, when it is one the model moves in.
    pub fn slot(&self, d: Dof) -> Option<usize> {
        (0..4).find(|&j| self.dofs[j] == d && self.active[j])
    }

    /// The slots the model moves in.
    pub fn on(&self) -> impl Iterator<Item = usize> + '_ {
        (0..4).filter(|&j| self.active[j])
    }

    /// The slots the model moves in whose DOF is among `dofs`.
    pub fn among(&self, dofs: &[Dof]) -> Vec<usize> {
        self.on()
            .filter(|&j| dofs.contains(&self.dofs[j]))
            .collect()
    }

    /// The DOFs the model moves in that run `f` has no fused velocity for.
    pub fn missing(&self, f: &crate::pool::fusion::Fused) -> Vec<Dof> {
        self.on()
            .map(|j| self.dofs[j])
            .filter(|&d| slot_channel(f, d).is_none())
            .collect()
    }

    /// The slot velocities of a body-velocity vector.
    pub fn of_nu(&self, nu: &Vec6) -> [f64; 4] {
        std::array::from_fn(|j| nu[self.nu(j)])
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

/// Roll and pitch of a model that moves in them beside the DOFs it is compared in (a six-DOF
/// model): their logged moments, and their fused rates (empty where not logged), which its
/// simulation starts from and is re-anchored to, as the validation's is. Without them the
/// model rolled and pitched under no moment from rest, its buoyancy level: on a simulated
/// BlueROV2 Heavy pitched up to 40 deg the diagnosis scored surge and sway at NMAE 0.84 and
/// 1.04 where the validation had 0.063 and 0.076.
#[derive(Debug, Clone, PartialEq)]
pub struct Tilt {
    pub cmd: Vec<[f64; 2]>,
    pub rate: [Vec<f64>; 2],
}

impl Tilt {
    pub fn of(r: &crate::pool::fusion::run::FusedRun) -> Tilt {
        let rate = |d: Dof| slot_channel(&r.fused, d).map_or_else(Vec::new, |(v, _, _)| v.to_vec());
        Tilt {
            cmd: (0..r.thrust.len())
                .map(|k| {
                    let tau = r.tau(k);
                    [tau[3], tau[4]]
                })
                .collect(),
            rate: [rate(Dof::Roll), rate(Dof::Pitch)],
        }
    }
}
