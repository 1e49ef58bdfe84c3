//! The cuts made to a loaded run's logs ([`timing`]), each said in its timing repairs, and
//! the run's sensor logs by name.

use super::PoolRun;
use super::csvlog::Log;
use super::timing;

/// How far beyond the command log's stretch a sensor's rows are kept when the command log
/// was cut at a stop, s: the smoothers' edges.
const STOP_MARGIN_S: f64 = 2.0;

impl PoolRun {
    /// The command log cut to its longest stretch without a stop ([`timing::cut_at_stops`]),
    /// and the sensor logs to that stretch give or take [`STOP_MARGIN_S`], each cut said.
    pub(super) fn cut_at_stops(&mut self, dir: &str) {
        let Some(r) = timing::cut_at_stops(&mut self.thrust) else {
            return;
        };
        self.repairs.push(format!("{}: {r}", self.command_path));
        let span = (self.thrust.t[0], self.thrust.t[self.thrust.len() - 1]);
        let cut: Vec<&str> = (self.sensors_mut().into_iter())
            .filter_map(|(name, log)| timing::keep_near(log, span, STOP_MARGIN_S).then_some(name))
            .collect();
        self.repairs.extend(cut.iter().map(|name| {
            format!("{dir}: the {name} rows more than {STOP_MARGIN_S} s outside that stretch are left out")
        }));
    }

    /// The command log cut to the span where every sensor log has data, the cut said in the
    /// timing repairs ([`timing::trim_to_overlap`]).
    pub fn trim_command_to_sensors(&mut self) {
        // Disjoint fields: the command log is trimmed while the sensor logs are read.
        let sensors: Vec<&Log> = [&self.uwb, &self.sonar, &self.imu, &self.depth, &self.nav]
            .into_iter()
            .flatten()
            .collect();
        if let Some(r) = timing::trim_to_overlap(&mut self.thrust, &sensors) {
            self.repairs.push(format!("{}: {r}", self.command_path));
        }
    }

    /// The sensor logs the run has, in the order their notes are listed.
    pub(super) fn sensor_logs(&self) -> impl Iterator<Item = &Log> {
        self.sensors().into_iter().map(|(_, l)| l)
    }

    /// The sensor logs the run has, by name, to repair.
    pub(super) fn sensors_mut(&mut self) -> Vec<(&'static str, &mut Log)> {
        [
            ("uwb", &mut self.uwb),
            ("sonar", &mut self.sonar),
            ("imu", &mut self.imu),
            ("depth", &mut self.depth),
            ("nav", &mut self.nav),
        ]
        .into_iter()
        .filter_map(|(n, l)| Some((n, l.as_mut()?)))
        .collect()
    }

    /// The sensor logs the run has, by name.
    pub fn sensors(&self) -> Vec<(&'static str, &Log)> {
        [
            ("uwb", &self.uwb),
            ("sonar", &self.sonar),
            ("imu", &self.imu),
            ("depth", &self.depth),
            ("nav", &self.nav),
        ]
        .into_iter()
        .filter_map(|(n, l)| Some((n, l.as_ref()?)))
        .collect()
    }
}
