//! `hydrofit design`: which run to fly next and what it will buy (see `design/`), from the
//! cache of the last build. Writes a folder a pool test can start from: the command
//! (`thrust.csv`), a `run.yaml`, the planned track (`plan.csv`, `trajectory.svg`) and
//! `design.json` with the standard errors now and predicted after, for the designed run and
//! for a PRBS of the same length and limits (`prbs_thrust.csv`).

use crate::core::dof::Dof;
use crate::core::model::motion::State;
use crate::core::model::{Plant, Pool};
use crate::design::written::{Row, Separation, Written};
use crate::design::{self, Candidate, DOFS, DT, Setup};
use crate::identify::result::FitResult;
use crate::pipeline::Plan;
use crate::pool::fusion::run::{FusedRun, load_for};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;
use std::process::ExitCode;

/// What the engineer asks of a design.
pub struct Ask<'a> {
    pub model: Option<&'a str>,
    pub out: &'a Path,
    pub duration_s: f64,
    pub margin_m: f64,
    pub pool: Option<Pool>,
    pub start: Option<[f64; 4]>,
    pub targets: &'a [String],
    pub draws: usize,
    pub seed: u64,
}

pub fn run(root: &Path, ask: &Ask) -> anyhow::Result<ExitCode> {
    let plan = Plan::load(root, crate::kinds::KINDS)?;
    let (f, runs) = model_and_runs(&plan, ask.model)?;
    let mut setup = setup(&f, &runs, &plan.graph.spec.vehicle, ask)?;
    let margin = look_alikes(&plan, &mut setup, &runs, ask);
    let (limits_from, runs_used) = (limits_source(&setup, &runs), run_names(&runs));
    let goal = match &setup.separate {
        Some((p, _)) => format!("telling {} from {}", p.kept, p.alike),
        None => setup
            .targets
            .iter()
            .map(|&j| setup.layout.name(j))
            .collect::<Vec<_>>()
            .join(", "),
    };
    eprintln!(
        "hydrofit: designing a {:.0} s run for {goal} from {} recorded run(s) ({} candidates)",
        ask.duration_s,
        runs.len(),
        (design::FAMILIES.len() + 1) * ask.draws
    );
    let bar = crate::core::progress::Progress::new().bar(100, "design");
    let best = design::search(&setup, ask.draws, ask.seed, &|x| {
        bar.set_position((100.0 * x) as u64)
    });
    bar.finish_and_clear();
    let best = best.ok_or_else(|| no_fit_message(&setup))?;
    let prbs = design::baseline(&setup, ask.seed).unwrap_or_else(|| best.clone());
    let written = Written {
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
        limits_from,
        parameters: rows(&f, &setup, &best, &prbs),
        runs: runs_used,
        separates: None,
    };
    let written = with_separation(written, &setup, &runs, margin, &best, &prbs);
    let dir = if ask.out.is_absolute() {
        ask.out.to_path_buf()
    } else {
        root.join(ask.out)
    };
    write(&dir, &written, &best, &prbs)?;
    print_table(&written);
    crate::outln!("wrote {}", dir.display());
    Ok(ExitCode::SUCCESS)
}

/// The fit stage asked for (or the pipeline's only fit of its own vehicle), and its training
/// runs as the pool stages fused them.
fn model_and_runs(plan: &Plan, model: Option<&str>) -> anyhow::Result<(FitResult, Vec<FusedRun>)> {
    let i = crate::cmd::export::pick_fit(plan, model)?;
    let cache = plan.cache();
    let f = crate::cmd::provenance::load_fit(plan, &cache, i)?;
    let vehicle = f.vehicle.clone().unwrap_or(plan.graph.spec.vehicle.clone());
    let mut runs = Vec::new();
    for r in &f.runs {
        let Some(j) = plan.graph.instances.iter().position(|x| x.id == r.id) else {
            continue;
        };
        anyhow::ensure!(
            cache.has(&plan.keys[j]),
            "pool run {} is out of date; run `hydrofit build` first",
            r.run
        );
        runs.push(load_for(&cache.object(&plan.keys[j]), &vehicle)?);
    }
    anyhow::ensure!(
        !runs.is_empty(),
        "model {} was identified from no pool run: a design predicts what a pool run adds to the runs a model was fitted to (a CFD-only model: add a first pool run, any excitation)",
        f.stage
    );
    Ok((f, runs))
}

fn setup(
    f: &FitResult,
    runs: &[FusedRun],
    pipeline_vehicle: &crate::core::model::Vehicle,
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
        design::info::output_information(&layout, &vehicle, &refs, plant.command_lag_s, &theta)
    } else {
        design::info::information(&layout, &vehicle, &refs, &sigma, skip_start_s)
    };
    let p = &f.fit.parameters;
    let reported: Vec<f64> = p.iter().map(|x| x.stderr).collect();
    let described: Vec<design::Reported> = p
        .iter()
        .enumerate()
        .map(|(j, x)| design::Reported {
            name: &x.name,
            value: x.value,
            stderr: x.stderr,
            identifiable: x.identifiable,
            constant: layout.slot(j).0 == crate::core::model::terms::Group::Constant,
        })
        .collect();
    let targets = design::targets(&described, ask.targets).map_err(anyhow::Error::msg)?;
    let (pool, start) = pool_and_start(ask, runs)?;
    Ok(Setup {
        limits: limits(&vehicle, runs),
        vehicle,
        plant,
        layout,
        reported,
        value: f.fit.parameters.iter().map(|x| x.value).collect(),
        before,
        output_error,
        theta,
        sigma,
        targets,
        pool,
        margin_m: ask.margin_m,
        duration_s: ask.duration_s,
        start,
        skip_start_s,
        anchor: runs.iter().find_map(|r| r.meta.tether_anchor_m),
        separate: None,
    })
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

/// When the last diagnosis of the model lists two effects it cannot tell apart (and no
/// parameters were named with --for), the design is for telling them apart: sets
/// `setup.separate` and returns the diagnosis's margin.
fn look_alikes(plan: &Plan, setup: &mut Setup, runs: &[FusedRun], ask: &Ask) -> Option<f64> {
    if !ask.targets.is_empty() {
        return None;
    }
    let cache = plan.cache();
    let g = &plan.graph;
    let d = (0..g.instances.len())
        .filter(|&i| g.stage_of(i).kind.name == "diagnose" && cache.has(&plan.keys[i]))
        .find_map(|i| {
            crate::core::fsutil::read_json::<crate::diagnose::Diagnosis>(
                &cache.object(&plan.keys[i]).join("diagnosis.json"),
            )
            .ok()
        })?;
    let pair = crate::design::separate::Pair::of(&d).into_iter().next()?;
    let recorded = recorded_runs(setup, runs);
    let noise = crate::design::separate::Noise::of(&recorded);
    setup.separate = Some((pair, noise));
    Some(d.criteria.min_noise_multiple)
}

/// The training runs as the diagnosis reads them (the command through the model's lag).
fn recorded_runs(setup: &Setup, runs: &[FusedRun]) -> Vec<crate::diagnose::Run> {
    runs.iter()
        .filter_map(|r| {
            crate::diagnose::Run::from_fused(&r.clone().with_command_lag(setup.plant.command_lag_s))
        })
        .collect()
}

fn with_separation(
    mut w: Written,
    setup: &Setup,
    runs: &[FusedRun],
    margin: Option<f64>,
    best: &Candidate,
    prbs: &Candidate,
) -> Written {
    if let (Some((pair, noise)), Some(margin)) = (&setup.separate, margin) {
        let recorded = recorded_runs(setup, runs)
            .iter()
            .map(|r| pair.separation(&setup.plant, r, noise))
            .fold(0.0, f64::max);
        w.separates = Some(Separation {
            kept: pair.kept.clone(),
            alike: pair.alike.clone(),
            recorded,
            designed: best.separation.unwrap_or(f64::NAN),
            prbs: prbs.separation.unwrap_or(f64::NAN),
            margin,
        });
    }
    w
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
fn limits(vehicle: &crate::core::model::Vehicle, runs: &[FusedRun]) -> [f64; 4] {
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
            unit: p.unit.clone(),
            target: setup.targets.contains(&j),
            stderr_now: p.stderr,
            predicted_after: best.se_after[j],
            predicted_after_prbs: prbs.se_after[j],
        })
        .collect()
}

fn thrust_csv(cmd: &[[f64; 4]]) -> String {
    let mut out = format!("t,{}\n", design::signal::LABELS.join(","));
    for (k, c) in cmd.iter().enumerate() {
        let _ = writeln!(
            out,
            "{:.2},{:.1},{:.1},{:.1},{:.1}",
            k as f64 * DT,
            c[0],
            c[1],
            c[2],
            c[3]
        );
    }
    out
}

fn plan_csv(c: &Candidate) -> String {
    let mut out = String::from("t,x_m,y_m,z_m,psi_rad,u,v,w,r\n");
    for (k, s) in c.states.iter().enumerate() {
        let _ = writeln!(
            out,
            "{:.2},{:.4},{:.4},{:.4},{:.5},{:.5},{:.5},{:.5},{:.5}",
            k as f64 * DT,
            s.pos[0],
            s.pos[1],
            s.pos[2],
            s.psi,
            s.nu[0],
            s.nu[1],
            s.nu[2],
            s.nu[5]
        );
    }
    out
}

fn run_yaml(w: &Written) -> String {
    // A run that is to tell two effects apart is held out: the diagnosis decides on held-out
    // costs. A run for the parameters trains.
    let role = if w.separates.is_some() {
        "validate"
    } else {
        "train"
    };
    format!(
        "role: {role}\ndescription: \"designed by hydrofit design for {}: {}; start at x {:.1} m, y {:.1} m, depth {:.1} m, heading {:.0} deg\"\npool: {{length_m: {}, width_m: {}, depth_m: {}}}\n",
        w.model,
        w.description.replace('"', "'"),
        w.start[0],
        w.start[1],
        w.start[2],
        w.start[3],
        w.pool.length_m,
        w.pool.width_m,
        w.pool.depth_m
    )
}

fn write(dir: &Path, w: &Written, best: &Candidate, prbs: &Candidate) -> anyhow::Result<()> {
    use crate::core::fsutil::{write_atomic, write_json};
    std::fs::create_dir_all(dir)?;
    write_atomic(&dir.join("thrust.csv"), thrust_csv(&best.cmd).as_bytes())?;
    write_atomic(
        &dir.join("prbs_thrust.csv"),
        thrust_csv(&prbs.cmd).as_bytes(),
    )?;
    write_atomic(&dir.join("plan.csv"), plan_csv(best).as_bytes())?;
    write_atomic(&dir.join("run.yaml"), run_yaml(w).as_bytes())?;
    write_atomic(
        &dir.join("trajectory.svg"),
        trajectory(w, best, prbs)?.as_bytes(),
    )?;
    write_json(&dir.join("design.json"), w)
}

/// The planned track seen from above, in the pool's outline and its margin.
fn trajectory(w: &Written, best: &Candidate, prbs: &Candidate) -> anyhow::Result<String> {
    use crate::core::plot::lines::{Chart, Series, chart};
    let (l, b, m) = (w.pool.length_m, w.pool.width_m, w.margin_m);
    let outline = |inset: f64| {
        let x = vec![inset, l - inset, l - inset, inset, inset];
        let y = vec![inset, inset, b - inset, b - inset, inset];
        (x, y)
    };
    let (px, py) = outline(0.0);
    let (mx, my) = outline(m);
    let xs = |c: &Candidate| c.states.iter().map(|s| s.pos[0]).collect::<Vec<_>>();
    let ys = |c: &Candidate| c.states.iter().map(|s| s.pos[1]).collect::<Vec<_>>();
    let (bx, by, qx, qy) = (xs(best), ys(best), xs(prbs), ys(prbs));
    chart(&Chart {
        title: "Planned track in the pool (seen from above)",
        x_desc: "x along the pool, m",
        y_desc: "y across, m",
        series: vec![
            Series {
                label: "designed run",
                x: &bx,
                y: &by,
                reference: false,
            },
            Series {
                label: "PRBS, same limits",
                x: &qx,
                y: &qy,
                reference: false,
            },
            Series {
                label: "pool walls",
                x: &px,
                y: &py,
                reference: true,
            },
            Series {
                label: "margin",
                x: &mx,
                y: &my,
                reference: true,
            },
        ],
        hlines: Vec::new(),
        stems: false,
    })
}

fn print_table(w: &Written) {
    crate::outln!("next run: {}", w.description);
    if let Some(s) = &w.separates {
        crate::outln!(
            "  tells {} from {}: their predicted recordings differ by {:.1} times the noise floor (the recorded runs: {:.1}; the PRBS: {:.1}; the diagnosis needs {:.1})",
            s.kept,
            s.alike,
            s.designed,
            s.recorded,
            s.prbs,
            s.margin
        );
    }
    crate::outln!(
        "  {:.0} s from x {:.1} m, y {:.1} m, depth {:.1} m, heading {:.0} deg; closest {:.2} m to a wall, the floor or the surface (margin {} m)",
        w.duration_s,
        w.start[0],
        w.start[1],
        w.start[2],
        w.start[3],
        w.clearance_m,
        w.margin_m
    );
    crate::outln!(
        "  {:<10} {:>12} {:>12} {:>12} {:>12}",
        "parameter",
        "value",
        "stderr now",
        "after run",
        "after PRBS"
    );
    for r in w.parameters.iter().filter(|r| r.target) {
        crate::outln!(
            "  {:<10} {:>12.4} {:>12.4} {:>12.4} {:>12.4}  {}",
            r.name,
            r.value,
            r.stderr_now,
            r.predicted_after,
            r.predicted_after_prbs,
            r.unit
        );
    }
}

/// `25x12x4` as a pool.
pub fn parse_pool(s: &str) -> Result<Pool, String> {
    let v: Vec<f64> = s
        .split(['x', 'X'])
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--pool {s}: expected LENGTHxWIDTHxDEPTH in m, e.g. 25x12x4"))?;
    match v[..] {
        [length_m, width_m, depth_m] if v.iter().all(|x| x.is_finite() && *x > 0.0) => Ok(Pool {
            length_m,
            width_m,
            depth_m,
        }),
        _ => Err(format!(
            "--pool {s}: expected three positive sizes LENGTHxWIDTHxDEPTH in m, e.g. 25x12x4"
        )),
    }
}

/// `x,y,z,heading_deg` as a start.
pub fn parse_start(s: &str) -> Result<[f64; 4], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--start {s}: expected x,y,z,heading_deg (m, m, m, deg)"))?;
    <[f64; 4]>::try_from(v)
        .ok()
        .filter(|a| a.iter().all(|x| x.is_finite()))
        .ok_or_else(|| format!("--start {s}: expected four numbers x,y,z,heading_deg"))
}
