//! The next run to fly: from the identified model, the runs it was identified from and the
//! parameters its report flags, the command profile (steps, PRBS or multisine, amplitudes and
//! time scales optimised) that most shrinks the flagged parameters' joint uncertainty
//! (D-optimal on them), flown with the model in the pool from a stated start, kept the stated
//! distance off the walls, the floor and the surface, and within the command limits. A PRBS
//! of the same length and limits is scored beside it, so the engineer sees what the design
//! buys over the default excitation.

pub mod files;
pub mod info;
pub mod propose;
pub mod report;
pub mod separate;
pub mod signal;
pub mod stage;
pub mod thrusters;
pub mod written;

use crate::core::dof::Dof;
use crate::core::model::motion::State;
use crate::core::model::{ParamLayout, Plant, Pool, Vehicle};
use crate::core::response::{Response, Series, Source};
use crate::core::rng::Rng;
use crate::diagnose::world::World;
use nalgebra::DMatrix;
use signal::Profile;
use std::collections::BTreeMap;

/// The commanded DOFs, in `thrust.csv`'s order, and their slots in a 6-vector.
pub const DOFS: [Dof; 4] = [Dof::Surge, Dof::Sway, Dof::Heave, Dof::Yaw];
/// The command log's period (20 Hz, as the pool runs log it).
pub const DT: f64 = 0.05;
/// The simulation's step within a command sample.
const MAX_STEP: f64 = 0.01;
/// How far inside the margin the plan's pilot starts pushing back (horizontally; 40 % of it
/// vertically), m.
pub const PILOT_ZONE_M: f64 = 2.0;

/// The optimality criterion on the targets.
#[derive(
    Debug,
    Clone,
    Copy,
    Default,
    PartialEq,
    Eq,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "snake_case")]
pub enum Criterion {
    /// D-optimal: the smallest joint confidence region (log det of the targets' covariance).
    #[default]
    D,
    /// A-optimal: the smallest mean relative variance of the targets (each scaled by its
    /// value, as the coefficients carry different units).
    A,
}

/// Everything a design is scored against.
pub struct Setup {
    pub vehicle: Vehicle,
    pub plant: Plant,
    pub layout: ParamLayout,
    /// The standard error the fit reported, per parameter of `layout`.
    pub reported: Vec<f64>,
    /// The values the fit reported.
    pub value: Vec<f64>,
    /// The recorded (training) runs' information, and the covariance it gives.
    pub before: DMatrix<f64>,
    pub covariance_before: DMatrix<f64>,
    /// Whether the fit minimised the output error (a prediction-error fit, a swarm on the
    /// output error): its information is then the simulation's sensitivity, not the
    /// regressor's.
    pub output_error: bool,
    /// The coefficients the plan is flown with (see `planning` in the command).
    pub theta: Vec<f64>,
    /// Each DOF's residual level, the rows' weights.
    pub sigma: BTreeMap<Dof, f64>,
    /// The parameters the design is for (indices into `layout`).
    pub targets: Vec<usize>,
    /// Parameters it would be for that are in roll or pitch, which a design does not command.
    pub not_designed: Vec<String>,
    /// Largest command per DOF of [`DOFS`] (0: the DOF is not commanded).
    pub limits: [f64; 4],
    pub pool: Pool,
    pub margin_m: f64,
    pub duration_s: f64,
    pub start: State,
    pub skip_start_s: f64,
    /// Where the tether enters the water, for effects that read it.
    pub anchor: Option<[f64; 3]>,
    /// Two look-alike effects to tell apart (the criterion is then their separation), with
    /// the recorded runs' noise and the model they were diagnosed beside.
    pub separate: Option<(separate::Pair, separate::Noise, Plant)>,
    /// How the targets' uncertainty is summed (D: joint volume; A: mean relative variance).
    pub criterion: Criterion,
}

/// A scored candidate: the profile as flown (amplitudes shrunk until it stays in the pool).
#[derive(Debug, Clone)]
pub struct Candidate {
    pub profile: Profile,
    pub cmd: Vec<[f64; 4]>,
    /// The planned states at the command's times.
    pub states: Vec<State>,
    /// log det of the targets' covariance after the run (smaller is better).
    pub criterion: f64,
    /// Predicted standard error of every parameter after the run.
    pub se_after: Vec<f64>,
    /// Closest the plan comes to a wall, the floor or the surface, m.
    pub clearance_m: f64,
    /// With [`Setup::separate`]: how far the recordings predicted with either look-alike
    /// differ on this run, in multiples of the noise floor.
    pub separation: Option<f64>,
}

impl Setup {
    /// The model in the pool, with the fit's command lag as the thrusters' first-order lag
    /// (the form the fit estimates it in).
    pub fn world(&self) -> World {
        let lag = crate::diagnose::hypothesis("thruster_lag").expect("a registered effect");
        let terms = match self.plant.command_lag_s > 0.0 {
            true => vec![(lag.build)(&[self.plant.command_lag_s, 1.0])],
            false => Vec::new(),
        };
        let mut w = World::new(self.plant.clone(), terms);
        w.pool = Some(self.pool);
        w
    }

    /// The information of `responses` as the fit's objective sees it.
    pub fn information(&self, responses: &[&Response]) -> DMatrix<f64> {
        if self.output_error {
            info::output_information(
                &self.layout,
                &self.vehicle,
                responses,
                self.plant.command_lag_s,
                &self.theta,
            )
        } else {
            info::information(
                &self.layout,
                &self.vehicle,
                responses,
                &self.sigma,
                self.skip_start_s,
            )
        }
    }

    /// `profile` flown from the start, its amplitudes (of the translations, then of all DOFs)
    /// shrunk by 0.7 until the plan keeps the margin; None when no shrink keeps it.
    pub fn evaluate(&self, profile: &Profile) -> Option<Candidate> {
        let world = self.world();
        let mut p = profile.scaled(1.0, [true; 4]);
        for attempt in 0..8 {
            let (cmd, states, response) = self.fly(&world, &p.commands(self.duration_s, DT));
            let clearance = self.clearance(&states);
            if clearance >= self.margin_m {
                return Some(self.score(p, cmd, states, &response, clearance));
            }
            let which = [true, true, true, attempt >= 4];
            p = p.scaled(0.7, which);
        }
        None
    }

    /// The command to log at a state: the excitation plus the pilot's correction, clipped at
    /// the limits and rounded to 0.1.
    fn command(&self, excitation: &[f64; 4], s: &State) -> [f64; 4] {
        let f = self.pilot(s);
        let (c, sn) = (s.psi.cos(), s.psi.sin());
        let body = [
            excitation[0] + c * f[0] + sn * f[1],
            excitation[1] - sn * f[0] + c * f[1],
            excitation[2] + f[2],
            excitation[3],
        ];
        std::array::from_fn(|i| {
            (body[i].clamp(-self.limits[i], self.limits[i]) * 10.0).round() / 10.0
        })
    }

    /// The pilot the plan flies with (its corrections are part of the command written): within
    /// [`PILOT_ZONE_M`] of the margin it pushes back towards the middle, proportional to the
    /// depth of the intrusion, and damps the approach; world-frame force [Fx, Fy, Fz], each at
    /// most the DOF's limit. Away from the walls the command is the excitation alone.
    fn pilot(&self, s: &State) -> [f64; 3] {
        let (c, sn) = (s.psi.cos(), s.psi.sin());
        let v = [
            c * s.nu[0] - sn * s.nu[1],
            sn * s.nu[0] + c * s.nu[1],
            s.nu[2],
        ];
        let p = &self.pool;
        let sizes = [p.length_m, p.width_m, p.depth_m];
        let limit = [
            self.limits[0].max(self.limits[1]),
            self.limits[0].max(self.limits[1]),
            self.limits[2],
        ];
        std::array::from_fn(|i| {
            let zone = if i < 2 {
                PILOT_ZONE_M
            } else {
                0.4 * PILOT_ZONE_M
            };
            let edge = (self.margin_m + zone).min(0.5 * sizes[i]);
            let push = limit[i] / zone;
            let x = s.pos[i];
            if x < edge {
                (push * (edge - x) - push * v[i].min(0.0)).min(limit[i])
            } else if x > sizes[i] - edge {
                (-push * (x - (sizes[i] - edge)) - push * v[i].max(0.0)).max(-limit[i])
            } else {
                0.0
            }
        })
    }

    /// The run flown with the model: the commands logged (excitation plus the pilot's
    /// corrections), the states at the command's times, and the run as the fit would read it.
    pub fn fly(
        &self,
        world: &World,
        excitation: &[[f64; 4]],
    ) -> (Vec<[f64; 4]>, Vec<State>, Response) {
        let substeps = (DT / MAX_STEP).round() as usize;
        let h = DT / substeps as f64;
        let mut s = self.start;
        let mut cmd = Vec::with_capacity(excitation.len());
        let mut states = Vec::with_capacity(excitation.len());
        for e in excitation {
            let c = self.command(e, &s);
            cmd.push(c);
            states.push(s);
            let six = [c[0], c[1], c[2], 0.0, 0.0, c[3]];
            for _ in 0..substeps {
                s = world.step(&s, &six, h);
            }
        }
        let response = self.response(world, &cmd, &states);
        (cmd, states, response)
    }

    fn response(&self, world: &World, cmd: &[[f64; 4]], states: &[State]) -> Response {
        let t: Vec<f64> = (0..cmd.len()).map(|k| k as f64 * DT).collect();
        let six: Vec<[f64; 6]> = cmd
            .iter()
            .map(|c| [c[0], c[1], c[2], 0.0, 0.0, c[3]])
            .collect();
        let mut dofs = BTreeMap::new();
        for d in self.vehicle.dofs.iter().filter(|d| DOFS.contains(d)) {
            let i = d.index();
            let mut s = Series {
                force: Vec::with_capacity(t.len()),
                velocity: Vec::with_capacity(t.len()),
                accel: Vec::with_capacity(t.len()),
                force_source: Source::Column,
                accel_source: Source::Column,
            };
            for (k, st) in states.iter().enumerate() {
                // The output error passes the command through the lag itself.
                s.force.push(match self.output_error {
                    true => six[k][i],
                    false => world.delivered(st, &six[k])[i],
                });
                s.velocity.push(st.nu[i]);
                s.accel.push(world.accel(st, &six[k])[i]);
            }
            dofs.insert(*d, s);
        }
        Response {
            t,
            dofs,
            attitude: Vec::new(),
        }
    }

    /// The smallest distance of the plan to a side wall, the floor or the surface.
    pub fn clearance(&self, states: &[State]) -> f64 {
        states.iter().fold(f64::INFINITY, |a, s| {
            let wall = self.pool.wall_distance(s.pos[0], s.pos[1]);
            let vertical = s.pos[2].min(self.pool.depth_m - s.pos[2]);
            let c = wall.min(vertical);
            if c.is_finite() {
                a.min(c)
            } else {
                f64::NEG_INFINITY
            }
        })
    }

    fn score(
        &self,
        profile: Profile,
        cmd: Vec<[f64; 4]>,
        states: Vec<State>,
        response: &Response,
        clearance_m: f64,
    ) -> Candidate {
        let added = self.information(&[response]);
        let after = info::covariance(&(&self.before + added));
        let se_after =
            info::predicted(&self.reported, &self.value, &self.covariance_before, &after);
        let separation = self.separate.as_ref().map(|(pair, noise, plant)| {
            pair.separation(plant, &self.as_run_for(plant, &cmd, &states), noise)
        });
        Candidate {
            profile,
            criterion: match (separation, self.criterion) {
                (Some(x), _) => -x,
                (None, Criterion::D) => info::log_det_block(&after, &self.targets),
                (None, Criterion::A) => {
                    info::log_relative_trace(&se_after, &self.theta, &self.targets)
                }
            },
            cmd,
            states,
            se_after,
            clearance_m,
            separation,
        }
    }

    /// The plan as the diagnosis of `plant` reads a run: the command (passed through that
    /// model's command lag, as the diagnosis does) and the planned track.
    pub fn as_run_for(
        &self,
        plant: &Plant,
        cmd: &[[f64; 4]],
        states: &[State],
    ) -> crate::diagnose::Run {
        let t: Vec<f64> = (0..cmd.len()).map(|k| k as f64 * DT).collect();
        let six: Vec<[f64; 6]> = cmd
            .iter()
            .map(|c| [c[0], c[1], c[2], 0.0, 0.0, c[3]])
            .collect();
        let lagged = plant.command(&t, &six);
        let col = |f: &dyn Fn(&State) -> f64| states.iter().map(f).collect::<Vec<f64>>();
        crate::diagnose::Run {
            name: "designed".into(),
            validate: true,
            slots: crate::diagnose::Slots::POOL,
            cmd: lagged
                .iter()
                .map(|c| [c[0], c[1], c[2], 0.0, 0.0, c[5]])
                .collect(),
            vel: [
                col(&|s| s.nu[0]),
                col(&|s| s.nu[1]),
                col(&|s| s.nu[2]),
                vec![0.0; t.len()],
                vec![0.0; t.len()],
                col(&|s| s.nu[5]),
            ],
            std: std::array::from_fn(|_| vec![0.0; t.len()]),
            noise_share: [1.0; crate::diagnose::SLOTS],
            pos: [col(&|s| s.pos[0]), col(&|s| s.pos[1]), col(&|s| s.pos[2])],
            psi: col(&|s| s.psi),
            t,
            pool: Some(self.pool),
            anchor: self.anchor,
            dead_reckoned: false,
            att: Default::default(),
            anchors_s: Vec::new(),
        }
    }
}

/// The families a design chooses among.
pub const FAMILIES: [&str; 3] = ["steps", "prbs", "multisine"];

/// The best of `draws` random candidates per family, then polished by as many local changes;
/// `progress` is told the share done.
pub fn search(setup: &Setup, draws: usize, seed: u64, progress: &dyn Fn(f64)) -> Option<Candidate> {
    let mut rng = Rng::derive(seed, "design/search");
    let total = (FAMILIES.len() + 1) * draws;
    let mut done = 0;
    let mut best: Option<Candidate> = None;
    let consider = |c: Option<Candidate>, best: &mut Option<Candidate>| {
        if let Some(c) = c
            && best.as_ref().is_none_or(|b| c.criterion < b.criterion)
        {
            *best = Some(c);
        }
    };
    for family in FAMILIES {
        for _ in 0..draws {
            let p = signal::random(family, setup.limits, &mut rng);
            consider(setup.evaluate(&p), &mut best);
            done += 1;
            progress(done as f64 / total as f64);
        }
    }
    for _ in 0..draws {
        if let Some(b) = &best {
            let p = signal::perturb(&b.profile, setup.limits, &mut rng);
            consider(setup.evaluate(&p), &mut best);
        }
        done += 1;
        progress(done as f64 / total as f64);
    }
    best
}

/// The default excitation to compare with: a PRBS at the full limits, held 1 to 3 s (as the
/// pool runs' PRBS are flown), shrunk like any candidate until it keeps the margin.
pub fn baseline(setup: &Setup, seed: u64) -> Option<Candidate> {
    setup.evaluate(&Profile::Prbs {
        hold_s: 2.0,
        amplitude: setup.limits,
        seed,
    })
}

/// What the fit says of one parameter, for choosing the targets.
pub struct Reported<'a> {
    pub name: &'a str,
    pub value: f64,
    pub stderr: f64,
    pub identifiable: bool,
    /// A constant force (X_0 ...): a nuisance term the runs' offsets set, designed for only
    /// when named.
    pub constant: bool,
}

/// Which parameters a design is for: those named, else the coefficients the fit flags as not
/// identifiable, else those whose standard error is above 10 % of their value, else all
/// coefficients (constant forces only when named).
pub fn targets(params: &[Reported], asked: &[String]) -> Result<Vec<usize>, String> {
    if !asked.is_empty() {
        return asked
            .iter()
            .map(|a| {
                params.iter().position(|p| p.name == a).ok_or_else(|| {
                    let names: Vec<&str> = params.iter().map(|p| p.name).collect();
                    format!(
                        "--for {a}: the model has no such parameter; it has {}",
                        names.join(", ")
                    )
                })
            })
            .collect();
    }
    let pick = |f: &dyn Fn(&Reported) -> bool| -> Vec<usize> {
        (0..params.len())
            .filter(|&j| !params[j].constant && f(&params[j]))
            .collect()
    };
    let flagged = pick(&|p| !p.identifiable);
    if !flagged.is_empty() {
        return Ok(flagged);
    }
    let loose = pick(&|p| p.stderr.is_nan() || p.stderr > 0.1 * p.value.abs());
    Ok(if loose.is_empty() {
        pick(&|_| true)
    } else {
        loose
    })
}
