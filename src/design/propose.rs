//! From a model, the runs it was fitted to and its diagnosis, to the proposed run: the setup
//! the candidates are scored against (the planning model, the information so far, the pool,
//! the limits), the search, the PRBS it is compared with, the look-alikes it is to separate
//! and the per-thruster commands. `hydrofit design` and the `design` stage both call
//! [`propose`]; the files it writes are in `files.rs`.

use super::thrusters::Mixed;
use super::written::{Row, Separation, Written};
use super::{Candidate, DOFS, Setup};
use crate::core::dof::Dof;
use crate::core::model::motion::State;
use crate::core::model::{Plant, Pool, Vehicle};
use crate::identify::result::FitResult;
use crate::pool::fusion::run::FusedRun;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What the engineer asks of a design (`hydrofit design`'s options; a `design` stage's
/// settings).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Ask {
    /// The fit stage whose model to improve (default: the pipeline's fit of its vehicle).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// The run's length, s.
    pub duration_s: f64,
    /// Distance to keep from the walls, the floor and the surface, m.
    pub margin_m: f64,
    /// The pool (default: the training runs' run.yaml).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pool: Option<Pool>,
    /// x, y, z (m) and heading (deg) the run starts from (default: the pool's middle, half
    /// depth, heading along its length).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start: Option<[f64; 4]>,
    /// Parameters to design for (default: those the report flags).
    #[serde(rename = "for", skip_serializing_if = "Vec::is_empty")]
    pub targets: Vec<String>,
    /// `d` (joint volume of the targets' confidence region, the default) or `a` (their mean
    /// relative variance).
    pub criterion: super::Criterion,
    /// Random candidates per family (steps, PRBS, multisine); as many local changes follow.
    pub candidates: usize,
    pub seed: u64,
}

impl Default for Ask {
    fn default() -> Self {
        Ask {
            model: None,
            duration_s: 120.0,
            margin_m: 1.0,
            pool: None,
            start: None,
            targets: Vec::new(),
            criterion: super::Criterion::D,
            candidates: 40,
            seed: 1,
        }
    }
}

/// The last diagnosis, and the model it diagnosed when that is another fit than the one the
/// run is designed for.
pub struct Diagnosed<'a> {
    pub diagnosis: &'a crate::diagnose::Diagnosis,
    /// The diagnosed model (`baseline.model`) when it is not the designed-for fit: its
    /// effects' parameters were fitted beside that model, so their separation is predicted
    /// with it (a CFD fit diagnosed, a pool-only fit designed for). None: the same model.
    pub plant: Option<Plant>,
}

/// The proposed run, the PRBS it was compared with, and what is written of them.
pub struct Proposal {
    pub written: Written,
    pub best: Candidate,
    pub prbs: Candidate,
    /// The command per thruster, where the vehicle describes its thrusters.
    pub mixed: Option<Mixed>,
}

/// The run to fly next for model `f`, fitted to `runs` (as fused), with the last diagnosis of
/// it (its look-alike effects are designed for when no parameter is asked for). `say` gets
/// one line on what is designed, `progress` the search's progress (0..1).
pub fn propose(
    f: &FitResult,
    runs: &[FusedRun],
    pipeline_vehicle: &Vehicle,
    diagnosis: Option<Diagnosed>,
    ask: &Ask,
    say: &dyn Fn(String),
    progress: &dyn Fn(f64),
) -> anyhow::Result<Proposal> {
    anyhow::ensure!(
        !runs.is_empty(),
        "model {} was identified from no pool run: a design predicts what a pool run adds to the runs a model was fitted to (a CFD-only model: add a first pool run, any excitation)",
        f.stage
    );
    anyhow::ensure!(
        ask.duration_s.is_finite()
            && ask.duration_s > 0.0
            && ask.margin_m.is_finite()
            && ask.margin_m >= 0.0,
        "a design needs a positive duration and a margin of 0 m or more (duration {} s, margin {} m)",
        ask.duration_s,
        ask.margin_m
    );
    let mut setup = setup(f, runs, pipeline_vehicle, ask)?;
    let apart = diagnosis.and_then(|d| look_alikes(d, &mut setup, runs, ask));
    let draws = ask.candidates.max(1);
    announce(&setup, ask, runs.len(), say);
    let best =
        super::search(&setup, draws, ask.seed, progress).ok_or_else(|| no_fit_message(&setup))?;
    let prbs = super::baseline(&setup, ask.seed).unwrap_or_else(|| best.clone());
    let mut written = Written {
        model: f.stage.clone(),
        method: f.method.clone(),
        profile: best.profile.clone(),
        description: best.profile.describe(),
        duration_s: ask.duration_s,
        start: start_row(&setup.start),
        pool: setup.pool,
        margin_m: setup.margin_m,
        clearance_m: best.clearance_m,
        prbs_clearance_m: prbs.clearance_m,
        limits: setup.limits,
        limits_from: limits_source(&setup, runs),
        parameters: rows(f, &setup, &best, &prbs),
        not_designed: setup.not_designed.clone(),
        runs: run_names(runs),
        criterion: match setup.separate {
            Some(_) => "separation".into(),
            None => format!("{:?}-optimal", ask.criterion),
        },
        separates: None,
        thrusters: None,
    };
    written.separates = separation(&setup, apart, &best, &prbs);
    let mixed = per_thruster(&setup.vehicle, &best);
    written.thrusters = mixed.as_ref().map(|m| m.summary.clone());
    Ok(Proposal {
        written,
        best,
        prbs,
        mixed,
    })
}

/// The designed command per thruster, where the vehicle describes its thrusters (and the
/// description can be used; the build has already said what is wrong with it otherwise).
fn per_thruster(vehicle: &Vehicle, best: &Candidate) -> Option<super::thrusters::Mixed> {
    let t = vehicle
        .thrusters
        .as_ref()
        .filter(|t| t.problems().is_empty())?;
    Some(super::thrusters::mix(&t.allocation(), &best.cmd))
}

/// Says what is designed for (and what cannot be), from how many runs, over how many
/// candidates.
fn announce(setup: &Setup, ask: &Ask, runs: usize, say: &dyn Fn(String)) {
    let goal = match &setup.separate {
        Some((p, _, _)) => format!("telling {} from {}", p.kept, p.alike),
        None => setup
            .targets
            .iter()
            .map(|&j| setup.layout.name(j))
            .collect::<Vec<_>>()
            .join(", "),
    };
    if !setup.not_designed.is_empty() {
        say(format!(
            "not designed for {}: in roll or pitch, which a design does not command (it designs X, Y, Z and N); fly steps or a PRBS of the roll and pitch moments for them",
            setup.not_designed.join(", ")
        ));
    }
    say(format!(
        "designing a {:.0} s run for {goal} from {runs} recorded run(s) ({} candidates)",
        ask.duration_s,
        (super::FAMILIES.len() + 1) * ask.candidates.max(1)
    ));
}

fn setup(
    f: &FitResult,
    runs: &[FusedRun],
    pipeline_vehicle: &Vehicle,
    ask: &Ask,
) -> anyhow::Result<Setup> {
    let vehicle = f.vehicle.clone().unwrap_or(pipeline_vehicle.clone());
    let layout = f.layout();
    let theta = planning_values(f, &layout);
    let mut plant = Plant::new(&vehicle, layout.to_hydro(&theta));
    plant.command_lag_s = f.plant(&vehicle).command_lag_s;
    let sigma: BTreeMap<Dof, f64> = f
        .fit
        .residual_sigma
        .iter()
        .filter_map(|(k, v)| Some((Dof::from_name(k)?, *v)))
        .collect();
    let skip_start_s = f.settings["skip_start_s"].as_f64().unwrap_or(0.0);
    let responses: Vec<_> = runs
        .iter()
        .filter_map(|r| r.as_response(&vehicle, None))
        .collect();
    let refs: Vec<_> = responses.iter().collect();
    let output_error = f.objective == crate::identify::result::Objective::OutputError;
    let before = if output_error {
        super::info::output_information(&layout, &vehicle, &refs, plant.command_lag_s, &theta)
    } else {
        super::info::information(&layout, &vehicle, &refs, &sigma, skip_start_s)
    };
    let p = &f.fit.parameters;
    let reported: Vec<f64> = p.iter().map(|x| x.stderr).collect();
    let described: Vec<super::Reported> = p
        .iter()
        .enumerate()
        .map(|(j, x)| super::Reported {
            name: &x.name,
            value: x.value,
            stderr: x.stderr,
            identifiable: x.identifiable,
            constant: layout.slot(j).0 == crate::core::model::terms::Group::Constant,
        })
        .collect();
    let all = super::targets(&described, &ask.targets).map_err(anyhow::Error::msg)?;
    let (targets, not_designed) = designable(&layout, all)?;
    let (pool, start) = pool_and_start(ask, runs)?;
    Ok(Setup {
        limits: limits(&vehicle, runs),
        vehicle,
        plant,
        layout,
        reported,
        value: f.fit.parameters.iter().map(|x| x.value).collect(),
        covariance_before: super::info::covariance(&before),
        before,
        output_error,
        theta,
        sigma,
        targets,
        not_designed,
        pool,
        margin_m: ask.margin_m,
        duration_s: ask.duration_s,
        start,
        skip_start_s,
        anchor: runs.iter().find_map(|r| r.meta.tether_anchor_m),
        separate: None,
        criterion: ask.criterion,
    })
}

/// The parameters of `targets` a design can reach (in surge, sway, heave or yaw, the DOFs it
/// commands) and the names of the others (in roll or pitch); none reachable is an error that
/// says so.
fn designable(
    layout: &crate::core::model::ParamLayout,
    targets: Vec<usize>,
) -> anyhow::Result<(Vec<usize>, Vec<String>)> {
    let (keep, other): (Vec<usize>, Vec<usize>) = targets
        .into_iter()
        .partition(|&j| super::DOFS.contains(&layout.slot(j).1));
    let names: Vec<String> = other.iter().map(|&j| layout.name(j)).collect();
    anyhow::ensure!(
        !keep.is_empty(),
        "the parameters to design for ({}) are in roll or pitch: a design commands X, Y, Z and N only (surge, sway, heave and yaw); fly steps or a PRBS of the roll and pitch moments by hand, or name parameters of the other DOFs with --for",
        names.join(", ")
    );
    Ok((keep, names))
}

/// The pool (asked, else the training runs') and the start (asked, else its middle at half
/// depth, heading along its length), which must keep the margin.
fn pool_and_start(ask: &Ask, runs: &[FusedRun]) -> anyhow::Result<(Pool, State)> {
    let pool = match ask.pool {
        Some(p) => p,
        None => runs.iter().find_map(|r| r.meta.pool).ok_or_else(|| {
            anyhow::anyhow!(
                "the training runs' run.yaml give no pool size: say it with --pool LENGTHxWIDTHxDEPTH (m), e.g. --pool 25x12x4"
            )
        })?,
    };
    let start = match ask.start {
        Some([x, y, z, psi]) => State {
            pos: [x, y, z],
            psi: psi.to_radians(),
            ..State::default()
        },
        None => State {
            pos: [pool.length_m / 2.0, pool.width_m / 2.0, pool.depth_m / 2.0],
            ..State::default()
        },
    };
    anyhow::ensure!(
        pool.wall_distance(start.pos[0], start.pos[1]) >= ask.margin_m
            && start.pos[2] >= ask.margin_m
            && start.pos[2] <= pool.depth_m - ask.margin_m,
        "the start ({:.1}, {:.1}, {:.1}) m is within the {} m margin of a wall, the floor or the surface of the {}x{}x{} m pool: give --start x,y,z,heading_deg inside it, or a smaller --margin",
        start.pos[0],
        start.pos[1],
        start.pos[2],
        ask.margin_m,
        pool.length_m,
        pool.width_m,
        pool.depth_m
    );
    Ok((pool, start))
}

/// When the diagnosis lists two effects it cannot tell apart (and no parameters were named
/// with --for), the design is for telling them apart: sets `setup.separate` and returns the
/// diagnosis's margin and how far the recorded runs tell the two apart (the largest).
fn look_alikes(
    d: Diagnosed,
    setup: &mut Setup,
    runs: &[FusedRun],
    ask: &Ask,
) -> Option<(f64, f64)> {
    if !ask.targets.is_empty() {
        return None;
    }
    let pair = super::separate::Pair::of(d.diagnosis).into_iter().next()?;
    let plant = d.plant.unwrap_or_else(|| setup.plant.clone());
    let recorded = recorded_runs(&plant, runs);
    let noise = super::separate::Noise::of(&recorded);
    let apart = (recorded.iter())
        .map(|r| pair.separation(&plant, r, &noise))
        .fold(0.0, f64::max);
    setup.separate = Some((pair, noise, plant));
    Some((d.diagnosis.criteria.min_noise_multiple, apart))
}

/// The training runs as the diagnosis of `plant` reads them (the command through its lag).
fn recorded_runs(plant: &Plant, runs: &[FusedRun]) -> Vec<crate::diagnose::Run> {
    runs.iter()
        .filter_map(|r| {
            crate::diagnose::Run::from_fused(
                &r.clone().with_command_of(plant),
                crate::diagnose::Slots::POOL,
            )
        })
        .collect()
}

/// How far the designed run, the PRBS and the recorded runs (`apart`: the margin, the
/// recorded runs' figure) tell the look-alikes apart.
fn separation(
    setup: &Setup,
    apart: Option<(f64, f64)>,
    best: &Candidate,
    prbs: &Candidate,
) -> Option<Separation> {
    let ((pair, _, _), (margin, recorded)) = (setup.separate.as_ref()?, apart?);
    Some(Separation {
        kept: pair.kept.clone(),
        alike: pair.alike.clone(),
        beside: pair.beside.clone(),
        recorded,
        designed: best.separation.unwrap_or(f64::NAN),
        prbs: prbs.separation.unwrap_or(f64::NAN),
        margin,
    })
}

/// The model the plan is flown with: the fit's, except that a coefficient the runs did not
/// determine (flagged as not identifiable) is replaced by the mean of the same kind of term
/// in the DOFs of its kind (translations or rotations) that they did determine, and a
/// constant force they did not determine by zero. A DOF no run excited has a model that says
/// nothing of how the vehicle moves in it; its neighbours' coefficients are a better guess
/// for planning, and the run then measures its own.
fn planning_values(f: &FitResult, layout: &crate::core::model::ParamLayout) -> Vec<f64> {
    use crate::core::model::terms::Group;
    let p = &f.fit.parameters;
    (0..p.len())
        .map(|j| {
            if p[j].identifiable {
                return p[j].value;
            }
            let (group, dof) = layout.slot(j);
            if group == Group::Constant {
                return 0.0;
            }
            let same: Vec<f64> = (0..p.len())
                .filter(|&k| {
                    let (g, d) = layout.slot(k);
                    p[k].identifiable && g == group && d.is_angular() == dof.is_angular()
                })
                .map(|k| p[k].value)
                .collect();
            match same.len() {
                0 => p[j].value,
                n => same.iter().sum::<f64>() / n as f64,
            }
        })
        .collect()
}

/// Per commanded DOF: the vehicle's `command_limits`, else the largest command the recorded
/// runs flew (the vehicle has delivered it); 0 for a DOF the model does not have.
fn limits(vehicle: &Vehicle, runs: &[FusedRun]) -> [f64; 4] {
    std::array::from_fn(|i| {
        let d = DOFS[i];
        if !vehicle.dofs.contains(&d) {
            return 0.0;
        }
        vehicle.command_limits.get(&d).copied().unwrap_or_else(|| {
            runs.iter()
                .flat_map(|r| r.thrust.iter().map(|c| c[i].abs()))
                .fold(0.0, f64::max)
        })
    })
}

fn limits_source(setup: &Setup, runs: &[FusedRun]) -> String {
    let own = DOFS
        .iter()
        .filter(|d| setup.vehicle.command_limits.contains_key(d))
        .count();
    match own {
        0 => format!(
            "the largest command of the {} recorded run(s) per DOF (set vehicle.command_limits to give the thrusters' own)",
            runs.len()
        ),
        _ => "vehicle.command_limits (pipeline.yaml); the largest recorded command where it names no limit".into(),
    }
}

fn run_names(runs: &[FusedRun]) -> Vec<String> {
    runs.iter().map(|r| r.meta.run.clone()).collect()
}

fn start_row(s: &State) -> [f64; 4] {
    [s.pos[0], s.pos[1], s.pos[2], s.psi.to_degrees()]
}

fn no_fit_message(setup: &Setup) -> anyhow::Error {
    anyhow::anyhow!(
        "no candidate stays {} m off the walls, floor and surface of the {}x{}x{} m pool, even at a small part of the limits: a smaller --margin, a shorter --duration, or a --start farther from the walls",
        setup.margin_m,
        setup.pool.length_m,
        setup.pool.width_m,
        setup.pool.depth_m
    )
}

fn rows(f: &FitResult, setup: &Setup, best: &Candidate, prbs: &Candidate) -> Vec<Row> {
    f.fit
        .parameters
        .iter()
        .enumerate()
        .map(|(j, p)| Row {
            name: p.name.clone(),
            value: p.value,
            planning_value: setup.theta[j],
            unit: p.unit.clone(),
            target: setup.targets.contains(&j),
            stderr_now: p.stderr,
            predicted_after: best.se_after[j],
            predicted_after_prbs: prbs.se_after[j],
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::model::ParamLayout;

    /// A design commands X, Y, Z and N: of a roll, pitch and yaw model's flagged parameters it
    /// designs for the yaw ones and names the others; with only roll and pitch ones it says
    /// it cannot.
    #[test]
    fn roll_and_pitch_parameters_are_named_not_designed() {
        let layout = ParamLayout::new(&[Dof::Roll, Dof::Pitch, Dof::Yaw]);
        let of = |name: &str| (0..layout.len()).find(|&j| layout.name(j) == name).unwrap();
        let (keep, named) = designable(&layout, vec![of("K_p"), of("N_r"), of("M_qdot")]).unwrap();
        assert_eq!(keep, vec![of("N_r")]);
        assert_eq!(named, vec!["K_p", "M_qdot"]);
        let err = designable(&layout, vec![of("K_p")])
            .unwrap_err()
            .to_string();
        assert!(err.contains("(K_p) are in roll or pitch"), "{err}");
    }
}
