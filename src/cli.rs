//! Command-line arguments and their dispatch.

use crate::cmd;
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, Parser)]
#[command(
    name = "hydrofit",
    version,
    about = "Identify an underwater vehicle's hydrodynamic model from CFD runs and pool tests, as a reproducible build"
)]
pub struct Cli {
    /// Project folder (holding pipeline.yaml and cases/).
    #[arg(long, global = true, default_value = ".")]
    pub project: PathBuf,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Build the given stages (default: all) and what they depend on; reuse every cached result.
    Build {
        /// Stage names or instance ids, e.g. `fit` or `cfd[surge_10N]`.
        stages: Vec<String>,
        /// Stages to run at once (default: the number of cores).
        #[arg(short, long)]
        jobs: Option<usize>,
        /// Say why each stage instance runs.
        #[arg(long)]
        explain: bool,
        /// Stop at a damaged cache object (a result whose files no longer match their recorded
        /// blake3) instead of moving it aside and rebuilding it.
        #[arg(long)]
        strict_cache: bool,
    },
    /// Check every cached result and the published report files against their recorded
    /// blake3; exit 1 when any is damaged or edited.
    Verify,
    /// List the stage instances a build would run and what makes each stale.
    Status {
        /// Also print every key field of each stale instance.
        #[arg(long)]
        explain: bool,
    },
    /// Remove the cache (.hydrofit/) and the generated report files.
    Clean,
    /// Trace a parameter to the stage, method, settings and input files that produced it.
    Provenance {
        /// Parameter name as in the report, e.g. X_uu or N_rdot.
        parameter: String,
        /// Only the model identified by this fit stage (a name under `stages:`), when several
        /// identify the parameter.
        #[arg(long, value_name = "STAGE")]
        model: Option<String>,
    },
    /// List what a vehicle's log holds (ROS 1 bag, ROS 2 bag (MCAP or .db3, or its folder),
    /// ArduPilot .BIN, .tlog, rostopic echo -p CSV files or other CSV tables with a time
    /// column): topics, types, counts, rates and, with --fields, every field's path.
    Inspect {
        /// The log, a rosbag2 folder, or a folder of CSV files with a time column.
        log: PathBuf,
        /// Also list every field of every topic by the path run.yaml's `log:` names it.
        #[arg(long)]
        fields: bool,
        /// A folder of message packages (`<pkg>/msg/*.msg`), a package or its `msg/` folder,
        /// searched first for the types a ROS 2 `.db3` bag does not define; repeatable.
        #[arg(long = "msg-folder", value_name = "DIR")]
        msg_folders: Vec<PathBuf>,
    },
    /// Write the identified model for a simulator or a toolbox (gazebo: gz-sim SDF; uuv:
    /// uuv_simulator; stonefish; mss: MATLAB; yaml: hydrofit's own), from the last build.
    Export {
        /// The formats to write.
        #[arg(long, value_enum, num_args = 1.., required = true)]
        to: Vec<crate::export::Format>,
        /// The fit stage whose model to write (default: the pipeline's fit of its vehicle).
        #[arg(long)]
        model: Option<String>,
        /// Folder to write into, relative to the project.
        #[arg(long, default_value = "reports")]
        out: PathBuf,
    },
    /// Propose the next pool run to fly (from the last build): the command profile that most
    /// shrinks the flagged parameters' uncertainty within the pool and the command limits;
    /// writes thrust.csv, run.yaml, the planned track and design.json with the standard
    /// errors now and predicted after (and after a PRBS of the same length, for comparison).
    Design {
        /// The fit stage whose model to improve (default: the pipeline's fit of its vehicle).
        #[arg(long)]
        model: Option<String>,
        /// Folder to write into, relative to the project.
        #[arg(long, default_value = "reports/design")]
        out: PathBuf,
        /// The run's length, s.
        #[arg(long, default_value_t = 120.0)]
        duration: f64,
        /// Distance to keep from the walls, the floor and the surface, m.
        #[arg(long, default_value_t = 1.0)]
        margin: f64,
        /// The pool, LENGTHxWIDTHxDEPTH in m (default: the training runs' run.yaml).
        #[arg(long, value_parser = crate::cmd::design::parse_pool)]
        pool: Option<crate::core::model::Pool>,
        /// Where the run starts: x,y,z,heading_deg (default: the pool's middle, half depth,
        /// heading along its length).
        #[arg(long, value_parser = crate::cmd::design::parse_start, allow_hyphen_values = true)]
        start: Option<[f64; 4]>,
        /// Parameters to design for, comma-separated (default: those the report flags as not
        /// identifiable, else those with a standard error above 10 % of their value).
        #[arg(long = "for", value_delimiter = ',')]
        targets: Vec<String>,
        /// d: the smallest joint confidence region of the targets; a: their smallest mean
        /// relative variance.
        #[arg(long, value_enum, default_value = "d")]
        criterion: crate::design::Criterion,
        /// Random candidates per family (steps, PRBS, multisine); as many local changes follow.
        #[arg(long, default_value_t = 40)]
        candidates: usize,
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Read a simulator's model file (SDF, URDF/xacro, Stonefish XML, MSS .m, hydrofit YAML) as
    /// hydrofit reads it, and print it as hydrofit's model file.
    ImportModel {
        file: PathBuf,
        #[arg(long, value_enum)]
        format: Option<crate::export::Format>,
    },
    /// Print the graph of stage instances, as text or Graphviz DOT.
    Graph {
        /// Print Graphviz DOT (for `dot -Tsvg`) instead of one line per instance with its inputs.
        #[arg(long)]
        dot: bool,
    },
    /// Write synthetic inputs from the digital twin of the reference vehicle.
    Twin {
        #[command(subcommand)]
        what: TwinCommand,
    },
    /// Write OpenFOAM cases: the 2D circular cylinder of the project's CFD series.
    Openfoam {
        #[command(subcommand)]
        what: OpenfoamCommand,
    },
    /// Benchmark QPSO on a seed-001-sized equation-error problem (52,690 rows, 12 parameters).
    Bench {
        /// l2 (quadratic form) or l1 (seed 001 eq. 14, every row per evaluation).
        #[arg(long, default_value = "l2")]
        norm: String,
        /// equation (seed 001 eq. 14), output (eq. 9: every candidate simulated on the
        /// 33 twin CFD cases), diagnosis (the whole diagnosis over 16 one-minute field-twin
        /// runs, against its 10 s target), pem (the default pool fit on the same 16 runs,
        /// against its 10 s target) or six-dof (seed 003's 241-term regression built and
        /// solved by QR and SVD, and the coupled model's simulation step).
        #[arg(long, default_value = "equation")]
        objective: String,
        /// Swarm size of the timed QPSO run.
        #[arg(long, default_value_t = 40)]
        population: usize,
        /// Iterations of the timed QPSO run.
        #[arg(long, default_value_t = 300)]
        iterations: usize,
        /// Also write the problem (rows, cols, then Phi, y, w as little-endian f64) for the
        /// Python comparison in bench/qpso_compare.py.
        #[arg(long)]
        export: Option<PathBuf>,
    },
}

#[derive(Debug, Subcommand)]
pub enum OpenfoamCommand {
    /// A new case of a body pushed by a constant force from rest in still water: mesh
    /// (blockMesh), pimpleFoam, sixDoFRigidBodyMotion. A 2D circular cylinder in surge (per
    /// metre of span), or a 3D sphere along any direction.
    New {
        /// The case folder to create (relative to the project), e.g. cases/cfd/openfoam/cylinder_2N.
        dir: PathBuf,
        /// The body: `cylinder` (2D, per metre of span) or `sphere` (3D).
        #[arg(long, value_enum, default_value_t = cmd::openfoam::Shape::Cylinder)]
        shape: cmd::openfoam::Shape,
        /// Applied force, N (per metre of span for the cylinder), along +x or `--direction`.
        #[arg(long)]
        force: f64,
        /// Body mass, kg (default: twice the displaced water: 62.83 kg per metre for the
        /// cylinder of radius 0.1 m, 8.38 kg for the sphere).
        #[arg(long)]
        mass: Option<f64>,
        /// Radius, m (the body's mesh and the time step follow it; for the cylinder the
        /// 27 x 22 m box does not, the sphere's box is 40 radii wide).
        #[arg(long, default_value_t = 0.1)]
        radius: f64,
        /// The sphere's direction of force and motion: x, y, z or three numbers `1,0,1`.
        #[arg(long, default_value = "x", allow_hyphen_values = true)]
        direction: String,
        /// Simulated time, s (default: long enough for about 2.5 m of travel for the
        /// cylinder, about 6 radii for the sphere).
        #[arg(long)]
        end_time: Option<f64>,
    },
}

/// Where twin runs are written, and their seed.
#[derive(Debug, Args)]
pub struct TwinRuns {
    /// Folder that receives one folder per run.
    #[arg(long, default_value = "cases/pool")]
    out: PathBuf,
    /// Folder for the truth (true motion, what the runs hide); keep it outside cases/.
    #[arg(long, default_value = "truth/pool")]
    truth: PathBuf,
    /// Seed of the manoeuvres and the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

#[derive(Debug, Subcommand)]
pub enum TwinCommand {
    /// STAR-CCM+ DFBI exports of the reference vehicle (seed 001's force levels).
    Starccm {
        /// Output folder.
        #[arg(long, default_value = "cases/cfd/starccm")]
        out: PathBuf,
        /// Seed of the numerical noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
    /// Free-running pool test folders (thrust log, UWB, sonar, IMU, depth) with concealed effects.
    Pool {
        #[command(flatten)]
        to: TwinRuns,
        /// Concealed effect as name=magnitude (repeatable); replaces the default set
        /// (thruster_lag=0.35, tether_drag=1.2). `--effect none` conceals nothing.
        #[arg(long = "effect")]
        effects: Vec<String>,
        /// Log the runs as a vehicle that logs only its own navigation (nav.csv: a DVL's
        /// velocity and an AHRS heading at 4-6 Hz, late; depth.csv) instead of the pool's
        /// UWB, sonar and IMU.
        #[arg(long)]
        navigation_log: bool,
    },
    /// Fly a designed run (`hydrofit design`'s thrust.csv) with the twin, open loop from the
    /// design's start, and write it as a pool run folder with its sensors and truth.
    Fly {
        /// The command to fly: a thrust.csv (the start is read from design.json beside it).
        thrust: PathBuf,
        /// The run's name (its folder under --out).
        #[arg(long)]
        name: String,
        /// Its role in the project (default: the role in the run.yaml beside the command, as
        /// `hydrofit design` wrote it, else train).
        #[arg(long)]
        role: Option<String>,
        #[command(flatten)]
        to: TwinRuns,
        /// Concealed effect as name=magnitude (repeatable), as for `twin pool`.
        #[arg(long = "effect")]
        effects: Vec<String>,
        /// Log the run as the vehicle's own navigation log, as `twin pool --navigation-log`.
        #[arg(long)]
        navigation_log: bool,
    },
    /// Field logs of a tethered 30 kg ROV under closed-loop control (commanded wrench by
    /// receive time, a DVL navigation log, depth, horizontal UWB; no IMU, no CFD), with hidden
    /// buoyancy, tether drag, thruster saturation and navigation latency.
    Field {
        #[command(flatten)]
        to: TwinRuns,
    },
    /// Trials of a 240 kg ROV actuated in all six DOFs (seed 003 Table II: closed-loop
    /// sinusoidal translations, open-loop sinusoidal moments) with a fully coupled truth: a
    /// command log with K and M, a DVL + inertial navigation log and a depth gauge.
    SixDof {
        #[command(flatten)]
        to: TwinRuns,
    },
    /// Dives of an Iver3-sized torpedo AUV (seed 004): four fins and a ducted thruster under a
    /// closed-loop depth and heading controller, two manoeuvring dives and one at constant
    /// depth and heading; fin and propeller commands (actuators.csv), DVL (nav.csv), AHRS
    /// (imu.csv) and depth; no thrust log.
    Auv {
        #[command(flatten)]
        to: TwinRuns,
    },
    /// Runs of a DSRV at 8 knots (seed 000): PRBS on the stern plane, open loop, one run whose
    /// stern plane loses 40 % of its effectiveness half-way; the stern-plane command logged
    /// (actuators.csv), a DVL + AHRS navigation log and depth; no thrust log.
    Dsrv {
        #[command(flatten)]
        to: TwinRuns,
    },
    /// Tank runs of a 1.6 m submarine model (seed 002): PRBS on the ordered depth through its
    /// depth controller, the elevator command logged (actuators.csv), inclinometer pitch and
    /// rate gyro (imu.csv) and depth; no thrust log. The truth: poles and pitch gain.
    Tank {
        #[command(flatten)]
        to: TwinRuns,
    },
    /// Proves the diagnosis on generated scenarios (each effect alone at two magnitudes, pairs,
    /// none) and prints the confusion table of concealed vs named effects.
    CheckDiagnosis {
        /// Seeds of the scenarios' manoeuvres and sensor noise.
        #[arg(long = "seed", default_values_t = [2u64, 3])]
        seeds: Vec<u64>,
        /// Render the runs as a vehicle that logs only its own navigation (a DVL's velocity
        /// and an AHRS heading at 4-6 Hz, depth; no UWB, sonar or IMU) instead of the pool's
        /// sensors.
        #[arg(long)]
        navigation_log: bool,
        /// A scenario of your own instead of the check's set: effects concealed together as
        /// `name=magnitude`, `,`-separated (the table's names and wave, skewed_thruster,
        /// surface_drag, tether_torsion, battery_sag, thrust_saturation, asymmetric_drag,
        /// inflow_loss, which the diagnosis must report unexplained); repeatable.
        #[arg(long = "scenario")]
        scenarios: Vec<String>,
        /// The vehicle that flies the runs: `reference` (seed 001's 35.2 kg ROV, diagnosed
        /// from its CFD fit), `small` (a BlueROV2 Heavy-sized 11.5 kg ROV) or `heavy` (the
        /// reference 1.5 times longer, 118.8 kg); `small` and `heavy` are diagnosed from their
        /// true coefficients each moved 1-2.5 %, the check's force-like magnitudes scaled to
        /// them.
        #[arg(long, default_value = "reference")]
        vehicle: String,
    },
}

pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    let root = cli.project;
    match cli.command {
        Command::Build {
            stages,
            jobs,
            explain,
            strict_cache,
        } => cmd::build::run(
            &root,
            stages,
            cmd::build::Flags {
                jobs,
                explain,
                strict_cache,
            },
        ),
        Command::Verify => cmd::verify::run(&root),
        Command::Status { explain } => cmd::status::run(&root, explain),
        Command::Clean => cmd::clean::run(&root),
        Command::Provenance { parameter, model } => {
            cmd::provenance::run(&root, &parameter, model.as_deref())
        }
        Command::Graph { dot } => cmd::graph::run(&root, dot),
        Command::Inspect {
            log,
            fields,
            msg_folders,
        } => cmd::inspect::run(&log, fields, &msg_folders),
        Command::Export { to, model, out } => cmd::export::run(&root, &to, model.as_deref(), &out),
        Command::ImportModel { file, format } => cmd::export::import(&file, format),
        asked @ Command::Design { .. } => design(&root, asked),
        Command::Twin { what } => twin(&root, what),
        Command::Bench {
            norm,
            objective,
            population,
            iterations,
            export,
        } => cmd::bench::run(&norm, &objective, population, iterations, export.as_deref()),
        Command::Openfoam {
            what:
                OpenfoamCommand::New {
                    dir,
                    shape,
                    force,
                    mass,
                    radius,
                    direction,
                    end_time,
                },
        } => cmd::openfoam::new(
            &root.join(dir),
            cmd::openfoam::New {
                shape,
                force,
                mass,
                radius,
                direction: &direction,
                end_time,
            },
        ),
    }
}

/// `hydrofit design`'s arguments, as the command reads them.
fn design(root: &std::path::Path, what: Command) -> anyhow::Result<ExitCode> {
    let Command::Design {
        model,
        out,
        duration,
        margin,
        pool,
        start,
        targets,
        criterion,
        candidates,
        seed,
    } = what
    else {
        unreachable!("called for the design command only")
    };
    let ask = crate::design::propose::Ask {
        model,
        duration_s: duration,
        margin_m: margin,
        pool,
        start,
        targets,
        criterion,
        candidates: candidates.max(1),
        seed,
    };
    cmd::design::run(root, &ask, &out)
}

/// The twin's commands: synthetic runs with a known truth.
fn twin(root: &std::path::Path, what: TwinCommand) -> anyhow::Result<ExitCode> {
    match what {
        TwinCommand::Starccm { out, seed } => cmd::twin::starccm(root, &out, seed),
        TwinCommand::Pool {
            to,
            effects,
            navigation_log,
        } => cmd::twin::pool(
            root,
            (&to.out, &to.truth, to.seed),
            &effects,
            cmd::twin::logs(navigation_log),
        ),
        TwinCommand::Fly {
            thrust,
            name,
            role,
            to,
            effects,
            navigation_log,
        } => cmd::twin::fly(
            root,
            &cmd::twin::Flight {
                thrust: &thrust,
                name: &name,
                role: role.as_deref(),
                out: &to.out,
                truth: &to.truth,
                seed: to.seed,
                effects: &effects,
                logs: cmd::twin::logs(navigation_log),
            },
        ),
        TwinCommand::Field { to } => cmd::twin::field(root, &to.out, &to.truth, to.seed),
        TwinCommand::SixDof { to } => cmd::twin::six_dof(root, &to.out, &to.truth, to.seed),
        TwinCommand::Auv { to } => cmd::twin::auv(root, &to.out, &to.truth, to.seed),
        TwinCommand::Dsrv { to } => cmd::twin::dsrv(root, &to.out, &to.truth, to.seed),
        TwinCommand::Tank { to } => cmd::twin::tank(root, &to.out, &to.truth, to.seed),
        TwinCommand::CheckDiagnosis {
            seeds,
            navigation_log,
            scenarios,
            vehicle,
        } => cmd::check_diagnosis::check_diagnosis(&seeds, navigation_log, &scenarios, &vehicle),
    }
}
