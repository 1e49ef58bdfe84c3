//! The diagnosis of a vehicle that logs its own navigation only (a DVL's velocity and an AHRS's
//! heading at 4-6 Hz, a depth gauge; no UWB, sonar or IMU), its position dead-reckoned from the
//! run's start: the twin's pool runs, flown with effects concealed, rendered as such a log
//! (`twin::pool::render_nav`, written apart from the diagnosis's forms).

use super::*;
use crate::twin::pool::Logs;

fn nav_diagnosis(effects: &[Effect], seed: u64) -> Diagnosis {
    let fused = scenario::fused_runs_seen(effects, seed, Logs::Navigation).unwrap();
    let d = full(&fused, &scenario::cfd_fit_plant(1).unwrap());
    eprintln!(
        "{effects:?} seed {seed}: {:?}\n  {}",
        d.effects
            .iter()
            .map(|e| e.name_with_alike())
            .collect::<Vec<_>>(),
        d.verdict
    );
    d
}

/// The navigation log's own lateness: each row carries the DVL's last ping (8 Hz,
/// [`crate::twin::pool::render_nav`]), 0-125 ms old, 62 ms on average. With the noise floor
/// measured apart from the manoeuvres the diagnosis sees it, as a lag of the thrusters or of
/// the sensors (look-alikes, listed together) no longer than one ping period. Panics when
/// `e` is anything else.
fn assert_the_logs_lateness(e: &crate::diagnose::result::Found, seed: u64) {
    let other = match e.name.as_str() {
        "thruster_lag" => "sensor_delay",
        "sensor_delay" => "thruster_lag",
        _ => panic!("seed {seed}: {} named where nothing is concealed", e.name),
    };
    let lag = e.lateness_s().expect("a lag or a delay");
    assert!(
        lag <= 0.125 && e.alike.iter().any(|a| a.name == other),
        "seed {seed}: {} of {lag} s",
        e.name_with_alike()
    );
}

/// Runs with nothing concealed stay clean on a navigation log as on the pool's sensors: the
/// log's own lateness, measured against the depth gauge, is taken out before the search
/// (`diagnose::latency`), and nothing is named, not even a lag.
#[test]
fn effect_free_navigation_logs_stay_clean() {
    for seed in [2, 3] {
        let d = nav_diagnosis(&[], seed);
        let taken = d
            .runs
            .latency_taken_out_s
            .expect("the log's latency taken out");
        assert!((0.02..=0.125).contains(&taken), "seed {seed}: {taken} s");
        assert!(d.effects.is_empty(), "seed {seed}: {}", d.verdict);
        assert!(
            d.verdict.starts_with("No missing physics"),
            "seed {seed}: {}",
            d.verdict
        );
        assert!(d.untested.is_empty(), "seed {seed}: {:?}", d.untested);
    }
}

/// Net buoyancy and a tether's drag (read on the dead-reckoned position) are named from a
/// navigation log, the buoyancy within 15 %; beside them, at most the log's own lateness.
#[test]
fn effects_are_named_from_a_navigation_log() {
    let d = nav_diagnosis(&[Effect::NetBuoyancy { force_n: 8.0 }], 3);
    assert_eq!(d.effects[0].name, "net_buoyancy", "{}", d.verdict);
    for e in &d.effects[1..] {
        assert_the_logs_lateness(e, 3);
    }
    let f = d.effects[0].parameters["force_n"];
    assert!((f - 8.0).abs() < 0.15 * 8.0, "force_n {f}");
    let e = Effect::from_arg("tether_drag=1.5").unwrap();
    let d = nav_diagnosis(std::slice::from_ref(&e), 2);
    assert_eq!(d.runs.dead_reckoned.len(), 6, "{:?}", d.runs);
    assert!(named(&d).contains(&"tether_drag"), "{}", d.verdict);
}

/// A periodic heave force (18 N at 0.42 Hz) is reported from a navigation log on every seed,
/// never "within noise", and discovery gives its closed form. The diagnosis reads the log's
/// velocities smoothed under the sensor's own noise (`pool::fusion::Tracked`): under the
/// larger figure the fits use, the 0.42 Hz motion was smoothed away (the heave error against
/// the truth 0.012 m/s rms where the wave is 0.018) and the held-out cost was 0.8-1.4 times
/// the floor ("no missing physics" on all three seeds).
#[test]
fn a_periodic_force_is_reported_from_a_navigation_log() {
    for seed in [3, 4, 5] {
        let d = nav_reported(&wave(18.0, 0.42), seed);
        let c = d
            .effects
            .iter()
            .find_map(|e| e.candidate.as_ref())
            .unwrap_or_else(|| panic!("seed {seed}: no closed form: {}", d.verdict));
        assert!(
            c.expression.contains("sin(2 pi 0.420 t"),
            "seed {seed}: {}",
            c.expression
        );
    }
}

/// A faster and weaker one (14 N at 0.545 Hz) too. The heave channel's noise used to come
/// out up to 3.3 times the 1.2 cm/s the twin adds on the runs that also move in heave (the
/// wave and the manoeuvre together were read as noise; 0.87-1.45 times now), and the verdict
/// said "no missing physics".
#[test]
fn a_faster_periodic_force_is_reported_from_a_navigation_log() {
    for seed in [3, 4, 5] {
        nav_reported(&wave(14.0, 0.545), seed);
    }
}

/// Weak effects near the noise floor: a 4 N heave force at 0.42 Hz (1.3-1.5 times the
/// floor, pooled; the line it leaves in heave's residual decides it) and a thrust that loses
/// 5 % a minute (2.7 times the floor on seed 3, over the 2.5 times that counts as noise; on
/// seed 2 it is 2.3 times and not reported). While the multiples were 5 (pooled) and 2 (with
/// a line), seed 57's runs of both read "no missing physics".
#[test]
fn weak_effects_near_the_floor_are_reported_from_a_navigation_log() {
    for seed in [2, 3] {
        nav_reported(&wave(4.0, 0.42), seed);
    }
    let sag = Effect::BatterySag {
        loss_per_minute: 0.05,
    };
    nav_reported(&sag, 3);
}

/// A surge thruster mounted 3 cm off the centre line and a tether's drag.
fn askew_thruster_and_tether() -> [Effect; 2] {
    [
        Effect::from_arg("skewed_thruster=0.03").unwrap(),
        Effect::from_arg("tether_drag=1.2").unwrap(),
    ]
}

/// A table effect masked by one outside the table: a surge thruster mounted 3 cm off the
/// centre line turns the vehicle as it surges, which turns the dead-reckoned track, and the
/// greedy rounds named no tether drag beside it (held-out cost 0.093 -> 0.042 with
/// `N += 0.030 X` alone, 8 times the floor). Tested again beside the discovered term, the
/// tether's drag is named within 25 % of the twin's, said in the verdict, and the yaw term
/// stays with its arm within 20 %.
#[test]
fn a_table_effect_masked_by_one_outside_it_is_named_beside_the_discovered_term() {
    let d = nav_diagnosis(&askew_thruster_and_tether(), 58);
    let tether = (d.effects.iter())
        .find(|x| x.name == "tether_drag")
        .unwrap_or_else(|| panic!("no tether drag: {}", d.verdict));
    let k = tether.parameters["coefficient"];
    assert!(
        (k - 1.2).abs() < 0.25 * 1.2,
        "coefficient {k}: {}",
        d.verdict
    );
    assert!(
        d.verdict.contains("not named before discovery"),
        "{}",
        d.verdict
    );
    let c = (d.effects.iter())
        .find_map(|x| x.candidate.as_ref())
        .unwrap_or_else(|| panic!("no closed form: {}", d.verdict));
    let arm = (c.parts())
        .flat_map(|p| &p.terms)
        .find(|t| t.term == "X")
        .map(|t| t.coefficient);
    assert!(
        arm.is_some_and(|a| (a - 0.03).abs() < 0.2 * 0.03),
        "{}",
        c.expressions()
    );
}

/// The same scenario on seed 57: `coupled_drag` wins the first round and, beside the
/// discovered terms, leaves 1.5 times the floor, so the tether's drag cannot earn a margin
/// over it; fitted in its place beside the terms it fits as well, and is listed as its
/// look-alike, never left out.
#[test]
fn a_look_alike_beside_the_discovered_terms_is_listed() {
    let d = nav_diagnosis(&askew_thruster_and_tether(), 57);
    let told = (d.effects.iter())
        .any(|x| x.name == "tether_drag" || x.alike.iter().any(|a| a.name == "tether_drag"));
    assert!(told, "{}", d.verdict);
    for x in d
        .effects
        .iter()
        .filter(|x| x.alike.iter().any(|a| a.name == "tether_drag"))
    {
        assert!(
            x.evidence.contains("Beside the discovered terms"),
            "{}",
            x.evidence
        );
    }
}

/// Propellers losing thrust to the inflow (F (1 - s / 4 m/s), s the speed along the push),
/// alone, on a navigation log. Re-estimating the model's drag by equation error took much of
/// it in (held-out cost 0.0289 -> 0.0132, 2.5 times the floor), and the search's first named
/// effect, `coupled_drag` (0.0136), left discovery nothing to find on top of it: the verdict
/// was drifted parameters. Discovery from the model without that effect finds Blanke's form
/// in surge, `X += c sqrt(|X|) u` with c in [-2.5, -1] (the twin's loss is about sqrt(|X|) / 4
/// of it), which beats that re-estimate: no named effect stays beside it, and the held-out
/// cost is more than halved. Re-estimated by output error the drag takes in more (0.0107, 2.1
/// times the floor), and the form found (`X += -0.23 |u| X`, the twin's -1 / 4, 0.0088) no
/// longer beats it by the margin: the verdict is then drift with the form listed beside it,
/// as what the runs cannot tell from drift.
#[test]
fn thrust_lost_to_the_inflow_is_found_from_a_navigation_log() {
    let d = nav_diagnosis(&[Effect::from_arg("inflow_loss=4").unwrap()], 73);
    if d.baseline.parameters_reestimated {
        assert!(
            d.verdict.contains("cannot tell it from drift")
                && (d.verdict.contains("sqrt(|X|) u") || d.verdict.contains("|u| X")),
            "{}",
            d.verdict
        );
        assert!(d.effects.is_empty(), "{}", d.verdict);
        return;
    }
    let c = (d.effects.iter())
        .find_map(|x| x.candidate.as_ref())
        .unwrap_or_else(|| panic!("no closed form: {}", d.verdict));
    super::discovery::surge_inflow_within(&d, c, -2.5..-1.0, 4.0);
    let claimed = super::discovery::named_beside(&d, true);
    assert!(claimed.is_empty(), "a named effect claimed it: {claimed:?}");
    assert!(
        c.cost_after_all() < 0.5 * d.baseline.validation_cost,
        "held-out cost {} -> {}",
        d.baseline.validation_cost,
        c.cost_after_all()
    );
}

/// The same loss on seed 74: the re-estimated model (held-out cost 0.0131) and Blanke's closed
/// form (0.0137) explained the held-out runs as well as each other, neither by the margin an
/// effect needs, and the verdict was drift with the form listed beside it; with a command
/// times its speed in the library, `X += -0.24 |u| X` (the twin's -1 / 4) is found and
/// `coupled_drag` dropped beside it. Whichever the verdict takes, it says the inflow's form:
/// as the closed form found, or listed beside the drift as what the runs cannot tell from it.
#[test]
fn a_closed_form_as_good_as_drift_is_listed_beside_it() {
    let d = nav_diagnosis(&[Effect::from_arg("inflow_loss=4").unwrap()], 74);
    assert!(
        d.verdict.contains("sqrt(|X|) u") || d.verdict.contains("|u| X"),
        "{}",
        d.verdict
    );
    if d.baseline.parameters_reestimated {
        assert!(
            d.verdict.contains("cannot tell it from drift"),
            "{}",
            d.verdict
        );
    }
}

fn wave(force_n: f64, frequency_hz: f64) -> Effect {
    Effect::Wave {
        force_n,
        frequency_hz,
        phase_rad: 0.3,
    }
}

fn nav_reported(e: &Effect, seed: u64) -> Diagnosis {
    let d = nav_diagnosis(std::slice::from_ref(e), seed);
    assert_reported(&d, e, seed);
    d
}

/// A late navigation log and slow thrusters look alike: each is named, or listed beside the
/// other, never the wrong one alone.
#[test]
fn a_late_navigation_log_is_not_taken_for_slow_thrusters() {
    for (arg, right, wrong, seed) in [
        ("sensor_delay=0.5", "sensor_delay", "thruster_lag", 2),
        ("thruster_lag=0.3", "thruster_lag", "sensor_delay", 3),
    ] {
        let e = Effect::from_arg(arg).unwrap();
        let d = nav_diagnosis(std::slice::from_ref(&e), seed);
        let listed = |name: &str| {
            d.effects
                .iter()
                .any(|x| x.name == name || x.alike.iter().any(|a| a.name == name))
        };
        assert!(listed(right), "{arg}: {}", d.verdict);
        let wrong_alone = d
            .effects
            .iter()
            .any(|x| x.name == wrong && x.alike.iter().all(|a| a.name != right));
        assert!(!wrong_alone, "{arg}: {wrong} named alone: {}", d.verdict);
    }
}

/// The yaw rate a navigation log's heading gives (no gyro) states its error: on every run of
/// seeds 2 and 3 its stated deviation is within a factor 1.5 of its true error. Under a
/// constant-rate heading model the likelihood took turns for rate noise and stated 1.9-2.4
/// times the error (`pool::fusion::heading`'s `Motion`).
#[test]
fn the_yaw_rate_from_a_heading_states_its_error() {
    for m in measured() {
        let ratio = m.counted[3] / m.truth[3];
        assert!(
            (1.0 / 1.5..1.5).contains(&ratio),
            "seed {} {}: yaw rate stated {:.4}, true error {:.4}",
            m.seed,
            m.run,
            m.counted[3],
            m.truth[3]
        );
    }
}

/// The sensor noise the fusion measures on a navigation log (what the diagnosis's noise floor
/// counts) is the log's, not the manoeuvres': on every run and channel u, v, w of seeds 2
/// and 3 (36 channels) it is within a factor 1.5 of the log's true noise, the spread of its
/// rows about the truth once the log's own lateness is taken out
/// (`twin::noise_about_lateness`). That noise is more than the DVL's 1.2 cm/s where the
/// vehicle accelerates: each row carries the last 8 Hz ping, 0-125 ms old, and the varying age
/// times the acceleration is an error no model explains (2.0-2.3 cm/s in surge on the PRBS
/// runs). Measured: 0.79-1.44 times it. Before the fit took a slow and a fast motion apart,
/// the PRBS runs read up to 3.6 times the DVL's noise.
#[test]
fn a_navigation_logs_noise_is_measured_within_a_factor_1_5() {
    for m in measured() {
        for j in 0..3 {
            let ratio = m.sensor[j] / m.own[j];
            assert!(
                (1.0 / 1.5..1.5).contains(&ratio),
                "seed {} {} {}: measured {:.4}, the log's noise {:.4}",
                m.seed,
                m.run,
                ["u", "v", "w"][j],
                m.sensor[j],
                m.own[j]
            );
        }
    }
}

/// Prints, per run and channel of the navigation-log rendering, the noise the diagnosis counts
/// (the tracked velocities' stated deviation times the channel's share) against those
/// velocities' true error, and the sensor noise measured per channel against the log's own
/// (the twin's DVL has 1.2 cm/s), for working on the noise floor:
/// `cargo test --release nav_noise_against_truth -- --ignored --nocapture`. Measured on seeds
/// 2 and 3: u, v, w at 0.41-1.26 times the true error (21 of 36 within 1.5; that error holds
/// the log's own lateness, each row carrying the DVL's last ping, which the diagnosis names as
/// a lag of about 0.05 s), the yaw rate from the heading alone at 0.71-1.21 times.
#[test]
#[ignore = "a measurement to print, not a check"]
fn nav_noise_against_truth() {
    for m in measured() {
        let mut line = format!("seed {} {:12}", m.seed, m.run);
        for j in 0..4 {
            line += &format!(
                "  {}: counted {:.4} true {:.4} ({:.2})",
                ["u", "v", "w", "r"][j],
                m.counted[j],
                m.truth[j],
                m.counted[j] / m.truth[j]
            );
        }
        for j in 0..3 {
            line += &format!(
                "  {} sensor {:.4} log {:.4} ({:.2})",
                ["u", "v", "w"][j],
                m.sensor[j],
                m.own[j],
                m.sensor[j] / m.own[j]
            );
        }
        eprintln!("{line}");
    }
}

/// One run of [`measured`]: per channel u, v, w, r the RMS stated deviation of the tracked
/// velocity (`counted`, times the channel's noise share) and its RMS true error (NaN where
/// the run has none); per channel u, v, w the sensor noise the fusion measured and the log's
/// own noise about its lateness.
struct Measured {
    seed: u64,
    run: String,
    counted: [f64; 4],
    truth: [f64; 4],
    sensor: [f64; 3],
    own: [f64; 3],
}

/// Every run of the navigation-log rendering of seeds 2 and 3, fused and set against its truth.
fn measured() -> Vec<Measured> {
    let mut rows = Vec::new();
    for seed in [2u64, 3] {
        let tmp = tempfile::tempdir().unwrap();
        let root = tmp.path();
        let specs = crate::twin::pool::default_runs();
        crate::twin::pool::write_runs_seen(
            &root.join("cases/pool"),
            &root.join("truth/pool"),
            &specs,
            &[],
            seed,
            Logs::Navigation,
        )
        .unwrap();
        for spec in &specs {
            rows.push(measure(root, seed, &spec.name));
        }
    }
    rows
}

/// [`Measured`] of run `name` written under `root`.
fn measure(root: &std::path::Path, seed: u64, name: &str) -> Measured {
    use crate::pool::import::csvlog;
    let read = |f: String| std::fs::read_to_string(root.join(f)).unwrap();
    let r = scenario::fuse_folder(root, name).unwrap();
    let truth = csvlog::parse_subset(
        "t",
        &read(format!("truth/pool/{name}.csv")),
        &["t", "u", "v", "w", "r"],
        "truth",
        2,
    )
    .unwrap();
    let nav = csvlog::parse_subset(
        "nav",
        &read(format!("cases/pool/{name}/nav.csv")),
        &["t", "u_m_s", "v_m_s", "w_m_s"],
        "nav",
        2,
    )
    .unwrap();
    let f = &r.fused;
    let (mut counted, mut true_error) = ([f64::NAN; 4], [f64::NAN; 4]);
    for j in 0..4 {
        let Some((v, s, share)) = f.tracking(j) else {
            continue;
        };
        let (mut se, mut ss) = (0.0, 0.0);
        for (k, &t) in f.t.iter().enumerate() {
            let e = v[k] - crate::pool::fusion::interp(&truth.t, &truth.cols[j], t);
            se += e * e;
            ss += (s[k] * share).powi(2);
        }
        let n = f.t.len() as f64;
        (counted[j], true_error[j]) = ((ss / n).sqrt(), (se / n).sqrt());
    }
    let sensor = |c: &str| {
        let (_, noise) = f.stats.nav_sensor.iter().find(|(n, _)| n == c).unwrap();
        noise.sigma
    };
    Measured {
        seed,
        run: name.to_string(),
        counted,
        truth: true_error,
        sensor: [sensor("u"), sensor("v"), sensor("w")],
        own: std::array::from_fn(|j| {
            crate::twin::noise_about_lateness(&nav.t, &nav.cols[j], &truth.t, &truth.cols[j], 0.25)
        }),
    }
}

/// Drag that grows near the surface (surge and sway, `c |u| u exp(-(z / 1 m)^2)`, outside the
/// table) on runs of which one comes up to the surface: the named look-alike the greedy
/// rounds take (`tether_drag`, 15 % of the mismatch on seed 72) is dropped, and the surge and
/// sway terms are found with the depth in them. The runs that stay deep cannot tell the
/// near-surface form from plain quadratic drag, and were once counted against it.
#[test]
fn drag_near_the_surface_is_found_and_its_look_alike_dropped() {
    let d = nav_diagnosis(&[Effect::from_arg("surface_drag=150").unwrap()], 72);
    let named: Vec<&str> = d.effects.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(named, ["unexplained"], "{}", d.verdict);
    let c = (d.effects.iter())
        .find_map(|x| x.candidate.as_ref())
        .unwrap_or_else(|| panic!("no closed form: {}", d.verdict));
    for dof in [Dof::Surge, Dof::Sway] {
        let near = (c.parts())
            .filter(|p| p.dof == dof)
            .flat_map(|p| &p.terms)
            .any(|t| t.term.contains("exp(-z") && t.coefficient < 0.0);
        assert!(near, "{dof:?}: {}", c.expressions());
    }
    let last = c.parts().last().unwrap().validation_cost_after;
    assert!(
        last < 2.0 * d.baseline.noise_cost,
        "{last} against a floor of {}",
        d.baseline.noise_cost
    );
}

/// Another vehicle: one of BlueROV2 Heavy size (11.5 kg, I_zz 0.16 kg m^2, drag mostly
/// quadratic: `twin::pool::Craft::small`), flown through the same manoeuvres with commands
/// scaled to its drag and logged as a navigation log, diagnosed from its true coefficients
/// each moved 1-2.5 % as a CFD fit would be. Nothing concealed stays clean; a tether's drag
/// and a thruster lag are named with their size.
#[test]
fn a_bluerov2_heavy_sized_vehicle_is_diagnosed_from_its_navigation_log() {
    let craft = crate::twin::pool::Craft::small();
    let plant = scenario::cfd_plant_of(&craft);
    let diagnosis = |effects: &[Effect]| {
        let fused = scenario::fused_runs_of(&craft, effects, 91, Logs::Navigation).unwrap();
        let d = full_of(&craft.vehicle, &fused, &plant);
        eprintln!("{effects:?}: {}", d.verdict);
        d
    };
    let clean = diagnosis(&[]);
    for e in &clean.effects {
        assert_the_logs_lateness(e, 91);
    }
    let named = |d: &Diagnosis, name: &str, param: &str| -> f64 {
        let e = d.effects.iter().find(|e| e.name == name);
        let e = e.unwrap_or_else(|| panic!("{name} not named: {}", d.verdict));
        e.parameters[param]
    };
    let tether = diagnosis(&[Effect::from_arg("tether_drag=0.6").unwrap()]);
    let k = named(&tether, "tether_drag", "coefficient");
    assert!((k / 0.6 - 1.0).abs() < 0.25, "tether drag {k} against 0.6");
    assert_eq!(tether.effects.len(), 1, "{}", tether.verdict);
    let lag = diagnosis(&[Effect::from_arg("thruster_lag=0.2").unwrap()]);
    let tau = named(&lag, "thruster_lag", "time_constant_s");
    assert!(
        (tau / 0.2 - 1.0).abs() < 0.15,
        "thruster lag {tau} s against 0.2 s"
    );
}

/// A sensor delay that takes nearly all of the mismatch alone, with a thruster lag beside it:
/// on the small vehicle's navigation log (0.4 s filtered at 0.2 s, and a 0.2 s lag) the delay
/// alone took the held-out cost to 2 % of the start (its filter at 0.35 s, holding the lag) and
/// the lag alone to 30 %; held beside that delay the lag gained nothing, and the verdict was
/// the delay and a remainder `unexplained`. Refitted together (a rival by the share it
/// removed, `select::strong_rivals`), each is named at its own time.
#[test]
fn a_delay_that_takes_most_of_the_mismatch_leaves_room_for_the_lag_beside_it() {
    let craft = crate::twin::pool::Craft::small();
    let plant = scenario::cfd_plant_of(&craft);
    let effects: Vec<Effect> = ["sensor_delay=0.4", "thruster_lag=0.2"]
        .iter()
        .map(|a| Effect::from_arg(a).unwrap())
        .collect();
    let fused = scenario::fused_runs_of(&craft, &effects, 311, Logs::Navigation).unwrap();
    let d = full_of(&craft.vehicle, &fused, &plant);
    let mut got: Vec<&str> = d.effects.iter().map(|e| e.name.as_str()).collect();
    got.sort();
    assert_eq!(got, ["sensor_delay", "thruster_lag"], "{}", d.verdict);
    let at = |n: &str, p: &str| d.effects.iter().find(|e| e.name == n).unwrap().parameters[p];
    let (delay, filter) = (
        at("sensor_delay", "delay_s"),
        at("sensor_delay", "filter_s"),
    );
    let lag = at("thruster_lag", "time_constant_s");
    assert!(
        (0.35..=0.45).contains(&delay)
            && (0.1..=0.3).contains(&filter)
            && (0.15..=0.25).contains(&lag),
        "delay {delay} s filtered at {filter} s, lag {lag} s"
    );
}

/// A 0.35 s sensor delay and a 0.15 s thruster lag on the reference vehicle's navigation log
/// (seed 312): the delay alone (0.458 s filtered at 0.271 s) leaves 1.6 noise floors, and fitted
/// together with it the lag comes out at its own time but lowers the held-out cost by under
/// the noise margin. The verdict names the delay and lists the lag beside it with its figure
/// (or names it, were the runs to carry it); before, the delay alone, the lag nowhere.
#[test]
fn a_lag_too_small_to_name_beside_a_delay_is_listed_beside_it() {
    let effects: Vec<Effect> = ["sensor_delay=0.35", "thruster_lag=0.15"]
        .iter()
        .map(|a| Effect::from_arg(a).unwrap())
        .collect();
    let d = nav_diagnosis(&effects, 312);
    let delay = (d.effects.iter())
        .find(|e| e.name == "sensor_delay")
        .unwrap_or_else(|| panic!("no delay named: {}", d.verdict));
    let lag = match d.effects.iter().find(|e| e.name == "thruster_lag") {
        Some(l) => l.parameters["time_constant_s"],
        None => {
            let b = (delay.possibly_beside.iter())
                .find(|b| b.name == "thruster_lag")
                .unwrap_or_else(|| panic!("the lag neither named nor listed: {}", d.verdict));
            assert!(
                b.validation_cost_with < b.validation_cost_without,
                "{}",
                delay.evidence
            );
            assert!(
                d.verdict.contains("thruster_lag possibly beside it"),
                "{}",
                d.verdict
            );
            b.parameters["time_constant_s"]
        }
    };
    assert!((0.1..=0.2).contains(&lag), "lag {lag} s: {}", d.verdict);
    let named: Vec<&str> = d.effects.iter().map(|e| e.name.as_str()).collect();
    assert!(
        named
            .iter()
            .all(|n| ["sensor_delay", "thruster_lag"].contains(n)),
        "{}",
        d.verdict
    );
}
