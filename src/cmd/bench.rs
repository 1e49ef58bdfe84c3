//! `hydrofit bench`: QPSO on a seed-001-sized equation-error problem, timed, with evaluations
//! per second and the work per evaluation, so the figure can be set against the machine's
//! compute bound and against the same algorithm in Python (bench/qpso_compare.py).

use crate::core::model::{Hydro, Vehicle};
use crate::core::response::Response;
use crate::core::rng::Rng;
use crate::identify::Regression;
use crate::identify::output_error::OutputError;
use crate::identify::swarm::qpso::Qpso;
use crate::identify::swarm::{Norm, Problem, Solver, Swarm};
use rayon::prelude::*;
use std::io::Write as _;
use std::path::Path;
use std::process::ExitCode;

/// Seed 001: "A total of 52,690 data were obtained".
pub const SEED_001_ROWS: usize = 52_690;

/// The twin's CFD cases, repeated with other noise seeds until the problem has `rows` rows.
pub fn seed_001_problem(rows: usize) -> Regression {
    let vehicle = Vehicle::reference();
    let cases = crate::twin::cfd::default_cases();
    let mut responses = Vec::new();
    let mut n = 0;
    let mut seed = 1;
    while n < rows {
        for c in &cases {
            let text = crate::twin::cfd::export(&vehicle, Hydro::reference(), c, seed);
            let opts = crate::cfd::starccm::ImportOptions {
                columns: &Default::default(),
                dofs: &vehicle.dofs,
                configured_force: Default::default(),
            };
            let r = crate::cfd::starccm::parse("twin.csv", &text, &opts)
                .expect("the twin writes valid exports")
                .response;
            n += r.len() * r.dofs.len();
            responses.push(r);
        }
        seed += 1;
    }
    let refs: Vec<_> = responses.iter().collect();
    let mut reg = Regression::build(&vehicle, &refs, 0.0);
    let p = reg.cols();
    reg.y.truncate(rows);
    reg.row_dof.truncate(rows);
    reg.phi.truncate(rows * p);
    reg
}

/// `hydrofit bench`: the objective `objective` (equation, output or diagnosis) timed, with
/// QPSO at `population` x `iterations`; `export` also writes the problem for the Python side.
pub fn run(
    norm: &str,
    objective: &str,
    population: usize,
    iterations: usize,
    export: Option<&Path>,
) -> anyhow::Result<ExitCode> {
    let norm = match norm {
        "l1" => Norm::L1,
        "l2" => Norm::L2,
        other => anyhow::bail!("--norm {other}: use l1 or l2"),
    };
    match objective {
        "equation" => {}
        "output" => return output_error(population, iterations, export),
        "diagnosis" => return diagnosis(),
        "pem" => return pem(),
        "six-dof" => return super::bench_six::run(),
        other => {
            anyhow::bail!("--objective {other}: use equation, output, pem, diagnosis or six-dof")
        }
    }
    let reg = seed_001_problem(SEED_001_ROWS);
    let (k, p) = (reg.rows(), reg.cols());
    let problem = Problem::new(&reg, &Vehicle::reference().rigid_mass(), norm);
    if let Some(path) = export {
        export_equation_problem(path, &reg, &problem)?;
    }
    let (swarm, secs) = timed_qpso(&problem, population, iterations);
    let evals = problem.evaluations();
    let (flops, bytes) = work_per_evaluation(norm, k, p, population);
    let rate = evals as f64 / secs;
    println!(
        "qpso {norm:?}: {k} rows x {p} parameters, population {population}, {iterations} iterations, {} threads",
        rayon::current_num_threads()
    );
    println!("  {evals} evaluations in {secs:.3} s = {rate:.0} evaluations/s");
    println!(
        "  per evaluation: {flops} flops, {bytes} bytes read -> {:.2} GFLOP/s, {:.2} GB/s",
        rate * flops as f64 / 1e9,
        rate * bytes as f64 / 1e9
    );
    let reps = if norm == Norm::L2 { 4_000 } else { 20 };
    print_objective_alone(&problem, &swarm, flops, reps);
    println!("  best cost {:.6e}", swarm.best_cost[swarm.g]);
    Ok(ExitCode::SUCCESS)
}

/// Writes the equation-error problem for bench/qpso_compare.py: rows, cols, then Phi, y, the
/// weights and the bounds, as little-endian f64.
fn export_equation_problem(path: &Path, reg: &Regression, problem: &Problem) -> anyhow::Result<()> {
    let (k, p) = (reg.rows(), reg.cols());
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    for v in [k as f64, p as f64]
        .iter()
        .chain(&reg.phi)
        .chain(&reg.y)
        .chain(problem.weights())
        .chain(&problem.lo)
        .chain(&problem.hi)
    {
        f.write_all(&v.to_le_bytes())?;
    }
    f.flush()?;
    eprintln!("wrote the problem to {}", path.display());
    Ok(())
}

/// QPSO seeded 1 on `problem` for `iterations`: the final swarm and the wall time, s.
fn timed_qpso(problem: &Problem, population: usize, iterations: usize) -> (Swarm, f64) {
    let mut rng = Rng::new(1);
    let mut solver = Qpso;
    let start = std::time::Instant::now();
    let mut swarm = solver.init(problem, &mut rng, population);
    for it in 0..iterations {
        solver.step(problem, &mut swarm, &mut rng, it as f64 / iterations as f64);
    }
    (swarm, start.elapsed().as_secs_f64())
}

/// (flops, bytes read) per evaluation of the equation-error cost on `k` rows x `p` parameters.
fn work_per_evaluation(norm: Norm, k: usize, p: usize, population: usize) -> (usize, usize) {
    match norm {
        // theta' A theta - 2 b.theta: p^2 multiply-adds and 2p more; A (p^2 doubles) stays in cache.
        Norm::L2 => (2 * p * p + 4 * p, 8 * (p * p + p)),
        // Per row: p multiply-adds (the weights folded into the rows and the fit started at
        // -w y) and the sum; the absolute value is a sign-bit clear, not counted. Each row
        // (p + 1 doubles) is read once per population (shared by all its particles).
        Norm::L1 => (k * (2 * p + 1), 8 * k * (p + 1) / population.max(1)),
    }
}

/// The objective alone: the final swarm evaluated repeatedly (no solver bookkeeping), the
/// best of five batches, as the bound is, set against the machine's measured FMA peak.
fn print_objective_alone(problem: &Problem, swarm: &Swarm, flops: usize, reps: usize) {
    let best = best_of_five(|| {
        for _ in 0..reps {
            std::hint::black_box(problem.cost_all(&swarm.x));
        }
    });
    let eval_rate = (reps * swarm.x.len()) as f64 / best;
    let peak = fma_peak();
    let achieved = eval_rate * flops as f64 / 1e9;
    println!("  objective alone: {eval_rate:.0} evaluations/s = {achieved:.1} GFLOP/s");
    println!(
        "  machine bound (measured FMA peak on {} threads): {peak:.1} GFLOP/s -> the objective runs at {:.0} % of it ({:.2}x from the bound)",
        rayon::current_num_threads(),
        100.0 * achieved / peak,
        peak / achieved
    );
}

/// QPSO with the simulator in the loop on the 33 twin CFD cases (seed 1, as shipped).
fn output_error(
    population: usize,
    iterations: usize,
    export: Option<&Path>,
) -> anyhow::Result<ExitCode> {
    let vehicle = Vehicle::reference();
    let responses = twin_cfd_responses(&vehicle)?;
    let refs: Vec<_> = responses.iter().collect();
    let reg = Regression::build(&vehicle, &refs, 0.0);
    let o = OutputError::new(&vehicle, &refs);
    let problem = Problem::new(&reg, &vehicle.rigid_mass(), Norm::L2);
    if let Some(path) = export {
        export_output_error_problem(path, &o, &problem)?;
    }
    let o_work = o.work();
    let six = o.six_dof();
    let problem = problem.with_output_error(o);
    let samples: usize = refs.iter().map(|r| r.len()).sum();
    let (swarm, secs) = timed_qpso(&problem, population, iterations);
    let evals = problem.evaluations();
    println!(
        "qpso output error: {} cases, {samples} samples (RK4, h <= 0.01 s), population {population}, {iterations} iterations, {} threads",
        refs.len(),
        rayon::current_num_threads()
    );
    println!(
        "  {evals} evaluations in {secs:.3} s = {:.1} evaluations/s ({:.2} ms each)",
        evals as f64 / secs,
        1e3 * secs / evals as f64
    );
    let (steps, values) = o_work;
    // RK4 steps as the lane kernel executes them, and per recorded value the weighted error,
    // its square and the sum (sqrt(w) (nu - v), then a multiply-add).
    let flops = steps * crate::core::model::lanes::flops_per_step(six) + values * 4;
    println!(
        "  per evaluation: {steps} RK4 steps ({} DOF kernel, {} flops each) and {values} compared values = {:.2} MFLOP",
        if six { 6 } else { 4 },
        crate::core::model::lanes::flops_per_step(six),
        flops as f64 / 1e6
    );
    print_objective_alone(&problem, &swarm, flops, 10);
    println!("  best cost {:.6e}", swarm.best_cost[swarm.g]);
    Ok(ExitCode::SUCCESS)
}

/// The twin's CFD cases of the reference vehicle, seed 1, imported as response tables.
fn twin_cfd_responses(vehicle: &Vehicle) -> anyhow::Result<Vec<Response>> {
    let opts = crate::cfd::starccm::ImportOptions {
        columns: &Default::default(),
        dofs: &vehicle.dofs,
        configured_force: Default::default(),
    };
    let responses = crate::twin::cfd::default_cases()
        .iter()
        .map(|c| {
            crate::cfd::starccm::parse(
                "twin.csv",
                &crate::twin::cfd::export(vehicle, Hydro::reference(), c, 1),
                &opts,
            )
            .map(|i| i.response)
        })
        .collect::<Result<_, _>>()?;
    Ok(responses)
}

/// Writes the output-error problem for bench/qpso_compare.py, as little-endian f64:
/// n_cases, then per case: n, t[n], tau[n x 4], nu[n x 4], weight[4]; then rigid mass
/// [m, m, m, Izz], bounds lo[12], hi[12] (parameter order of the report).
fn export_output_error_problem(
    path: &Path,
    o: &OutputError,
    problem: &Problem,
) -> anyhow::Result<()> {
    let idx = [0usize, 1, 2, 5];
    let mut v: Vec<f64> = vec![o.responses.len() as f64];
    for (r, w) in o.responses.iter().zip(&o.weight) {
        v.push(r.len() as f64);
        v.extend(&r.t);
        for k in 0..r.len() {
            let tau = r.tau(k);
            v.extend(idx.iter().map(|&i| tau[i]));
        }
        for k in 0..r.len() {
            let nu = r.nu(k);
            v.extend(idx.iter().map(|&i| nu[i]));
        }
        v.extend(idx.iter().map(|&i| w[i]));
    }
    let m = o.vehicle.rigid_mass();
    v.extend(idx.iter().map(|&i| m[i]));
    v.extend(&problem.lo);
    v.extend(&problem.hi);
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    for x in v {
        f.write_all(&x.to_le_bytes())?;
    }
    f.flush()?;
    Ok(())
}

/// The machine's double-precision multiply-add bound, measured: twelve independent FMA chains
/// of one vector register each on every core (AVX-512 when the CPU has it, else AVX2, else
/// scalar) - enough chains to cover the FMA latency on two pipes, few enough to stay in
/// registers - in GFLOP/s.
pub fn fma_peak() -> f64 {
    #[inline(always)]
    fn chains<const FMA: bool, const L: usize>(n: usize) -> f64 {
        let mut acc = [[1.0f64; L]; 12];
        let (a, b) = (0.999_999_9, 1e-9);
        for _ in 0..n {
            for v in acc.iter_mut() {
                for x in v.iter_mut() {
                    *x = if FMA { x.mul_add(a, b) } else { *x * a + b };
                }
            }
        }
        acc.iter().flatten().sum()
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,fma")]
    fn chains512(n: usize) -> f64 {
        chains::<true, 8>(n)
    }
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn chains256(n: usize) -> f64 {
        chains::<true, 4>(n)
    }
    // (lanes, run): the work per call is n x 12 chains x lanes multiply-adds.
    let pick = || -> (usize, fn(usize) -> f64) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: features checked just above.
                return (8, |n| unsafe { chains512(n) });
            }
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: features checked just above.
                return (4, |n| unsafe { chains256(n) });
            }
        }
        (1, chains::<false, 1>)
    };
    let (lanes, run) = pick();
    let n = 2_000_000;
    let threads = rayon::current_num_threads();
    let secs = best_of_five(|| {
        std::hint::black_box((0..threads).into_par_iter().map(|_| run(n)).sum::<f64>());
    });
    (threads * n * 12 * lanes * 2) as f64 / secs / 1e9
}

/// The shortest of five timed runs of `f`, in seconds: another process on the machine can
/// only slow a run down.
fn best_of_five(f: impl Fn()) -> f64 {
    (0..5)
        .map(|_| {
            let start = std::time::Instant::now();
            f();
            start.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Runs of the field twin for the diagnosis benchmark: `n` one-minute flights, every fourth
/// held out.
fn field_specs(n: usize) -> Vec<crate::twin::field::RunSpec> {
    let flights = crate::twin::field::default_runs();
    (0..n)
        .map(|i| {
            let mut r = flights[i % flights.len()].clone();
            r.name = format!("{}_{i:02}", r.name);
            r.role = if i % 4 == 3 {
                "validate".into()
            } else {
                "train".into()
            };
            r.duration_s = 60.0;
            r
        })
        .collect()
}

/// The diagnosis over 16 one-minute field runs, as `examples/field_rov` runs it (a pool-only
/// least-squares fit, `horizon_s: auto`), timed against the 10 s target on the machine.
/// 16 one-minute field-twin runs, fused, with the field vehicle (its thruster limits declared).
type FieldRuns = (
    tempfile::TempDir,
    Vec<crate::pool::fusion::run::FusedRun>,
    crate::core::model::Vehicle,
);

fn field_runs() -> anyhow::Result<FieldRuns> {
    let tmp = tempfile::tempdir()?;
    let specs = field_specs(16);
    let hidden = crate::twin::field::Hidden::default();
    crate::twin::field::write_runs(
        &tmp.path().join("cases/pool"),
        &tmp.path().join("truth"),
        &specs,
        &hidden,
        1,
    )?;
    let mut vehicle = crate::twin::field::vehicle();
    vehicle.command_limits = [
        (crate::core::dof::Dof::Surge, hidden.limits[0]),
        (crate::core::dof::Dof::Sway, hidden.limits[1]),
        (crate::core::dof::Dof::Heave, hidden.limits[2]),
        (crate::core::dof::Dof::Yaw, hidden.limits[3]),
    ]
    .into_iter()
    .collect();
    let fused: Vec<crate::pool::fusion::run::FusedRun> = specs
        .par_iter()
        .map(|spec| {
            crate::cmd::scenario::fuse_folder(tmp.path(), &spec.name).map(|r| r.clip_to(&vehicle))
        })
        .collect::<anyhow::Result<_>>()?;
    Ok((tmp, fused, vehicle))
}

/// The training runs of `fused` as responses.
fn training(
    fused: &[crate::pool::fusion::run::FusedRun],
    vehicle: &crate::core::model::Vehicle,
) -> Vec<crate::core::response::Response> {
    fused
        .iter()
        .filter(|r| r.meta.role == crate::pool::import::Role::Train)
        .filter_map(|r| r.as_response(vehicle, None))
        .collect()
}

/// `--objective pem`: the default pool fit (least squares, then Levenberg-Marquardt on the
/// output error of the training runs, the constants the user did not list and the sway-yaw
/// coupling chosen by cross-validation and the fit made again without those dropped) on the
/// 16 field-twin
/// runs, against its 10 s target.
fn pem() -> anyhow::Result<ExitCode> {
    use crate::core::dof::Dof;
    let (_tmp, fused, mut vehicle) = field_runs()?;
    vehicle.constant_force = vec![Dof::Heave];
    let train = training(&fused, &vehicle);
    use crate::identify::constants::{Candidate, with_couplings};
    let mut optional: Vec<Candidate> = (vehicle.dofs.iter())
        .filter(|d| **d != Dof::Heave)
        .map(|d| Candidate::Constant(*d))
        .collect();
    vehicle.constant_force = vehicle.dofs.clone();
    optional.extend(with_couplings(&mut vehicle));
    let method = crate::identify::Method::parse("pem", Default::default())
        .map_err(|e| anyhow::anyhow!(e))?;
    let start = std::time::Instant::now();
    let data = crate::identify::fit::Data {
        vehicle: &vehicle,
        cases: Vec::new(),
        pool: train.iter().collect(),
        skip_start_s: 0.0,
    };
    let req = crate::identify::fit::Request::plain(&method, &optional);
    let id = crate::identify::fit::identify(&data, &req)?;
    let secs = start.elapsed().as_secs_f64();
    let (fit, r) = (&id.fit, id.fit.refinement.as_ref());
    println!(
        "pem: {} one-minute field-twin training runs ({} equation rows, {} parameters), {} threads",
        train.len(),
        id.rows,
        fit.parameters.len(),
        rayon::current_num_threads()
    );
    println!(
        "  {secs:.2} s (target: 16 one-minute runs under 10 s on 2 cores); {} Levenberg-Marquardt steps, output error {:.4} -> {:.4}",
        r.map_or(0, |r| r.steps),
        r.map_or(f64::NAN, |r| r.start_cost),
        fit.objective_value.unwrap_or(f64::NAN)
    );
    let chosen = id
        .notes
        .iter()
        .find(|n| n.starts_with("constant forces chosen"));
    println!("  {}", chosen.map_or("no constants chosen", |n| n.as_str()));
    Ok(ExitCode::SUCCESS)
}

fn diagnosis() -> anyhow::Result<ExitCode> {
    use crate::identify::Estimator as _;
    let (_tmp, fused, vehicle) = field_runs()?;
    let train = training(&fused, &vehicle);
    let refs: Vec<&crate::core::response::Response> = train.iter().collect();
    let fit = crate::identify::ols::Ols.fit(
        &Regression::build(&vehicle, &refs, 0.0),
        &Default::default(),
    )?;
    let theta: Vec<f64> = fit.parameters.iter().map(|p| p.value).collect();
    let plant = crate::core::model::Plant::new(
        &vehicle,
        crate::core::model::ParamLayout::of(&vehicle).to_hydro(&theta),
    );
    let crit = crate::diagnose::Criteria {
        horizon_s: crate::core::model::stability::Horizon::Auto,
        ..Default::default()
    };
    let start = std::time::Instant::now();
    let (d, _) = crate::diagnose::diagnose(&vehicle, "fit", &plant, &fused, &crit, &|_| {})?;
    let secs = start.elapsed().as_secs_f64();
    let names: Vec<&str> = d.effects.iter().map(|e| e.name.as_str()).collect();
    println!(
        "diagnosis: 16 one-minute field-twin runs (12 train, 4 held out), {} threads",
        rayon::current_num_threads()
    );
    println!("  {secs:.2} s (target: under 10 s on 2 cores); named {names:?}");
    Ok(ExitCode::SUCCESS)
}
