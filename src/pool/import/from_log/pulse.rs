//! PWM outputs that carry no pulse. An autopilot logs a servo output it does not drive as 0
//! (ArduPilot's `RCOU` and MAVLink's `SERVO_OUTPUT_RAW` for a channel with no function, or
//! every channel before the outputs start): the ESC then gets no signal and the thruster
//! stops. Read through the curve, 0 us would be far below its end, full reverse thrust; it is
//! read as neutral instead, and said.

/// A logged PWM value below this is no servo pulse (servo and ESC pulses are 800-2200 us).
const NO_PULSE_BELOW_US: f64 = 500.0;

/// The per-thruster PWM rows with every value that is no pulse read as `neutral_us`, and the
/// notes naming the thrusters (1-based, in `vehicle.thrusters`' order) that had one: a
/// thruster with no pulse in the whole run is likely one that `vehicle.thrusters` lists and
/// the vehicle lacks.
pub(super) fn as_neutral(
    rows: &[Vec<f64>],
    neutral_us: f64,
    topic: &str,
    shown: &str,
) -> (Vec<Vec<f64>>, Vec<String>) {
    let n = rows.first().map_or(0, Vec::len);
    let mut off = vec![0usize; n];
    let out = rows
        .iter()
        .map(|r| {
            (r.iter().enumerate())
                .map(|(j, &c)| match c < NO_PULSE_BELOW_US {
                    true => {
                        off[j] += 1;
                        neutral_us
                    }
                    false => c,
                })
                .collect()
        })
        .collect();
    let name = |js: &[usize]| {
        let list: Vec<String> = js.iter().map(|j| (j + 1).to_string()).collect();
        match js.len() {
            1 => format!("thruster {}", list[0]),
            _ => format!("thrusters {}", list.join(", ")),
        }
    };
    let mut notes = Vec::new();
    let always: Vec<usize> = (0..n).filter(|&j| off[j] == rows.len()).collect();
    if !always.is_empty() {
        notes.push(format!(
            "{shown}: {} on `{topic}` get no pulse (PWM 0) in the whole run: read as no thrust; if the vehicle has fewer thrusters than vehicle.thrusters lists, describe the ones it has (`layout: bluerov2` for six)",
            name(&always)
        ));
    }
    for j in (0..n).filter(|&j| off[j] > 0 && off[j] < rows.len()) {
        notes.push(format!(
            "{shown}: {} on `{topic}` gets no pulse (PWM under {NO_PULSE_BELOW_US} us: its output off, as before the autopilot drives it) in {} of {} messages: read as no thrust there",
            name(&[j]),
            off[j],
            rows.len()
        ));
    }
    (out, notes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Channels 7 and 8 of a six-thruster vehicle read with an eight-thruster layout, and a
    /// channel off for a while: each is neutral where it has no pulse, and said.
    #[test]
    fn no_pulse_is_neutral_and_said() {
        let rows = vec![
            vec![1500.0, 1600.0, 0.0, 0.0],
            vec![0.0, 1620.0, 0.0, 0.0],
            vec![1550.0, 1640.0, 0.0, 0.0],
        ];
        let (got, notes) = as_neutral(&rows, 1500.0, "RCOU", "small.BIN");
        assert_eq!(got[1], [1500.0, 1620.0, 1500.0, 1500.0]);
        assert_eq!(got[2], [1550.0, 1640.0, 1500.0, 1500.0]);
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(notes[0].starts_with("small.BIN: thrusters 3, 4 on `RCOU` get no pulse"));
        assert!(notes[1].contains("thruster 1 on `RCOU` gets no pulse"));
        assert!(notes[1].contains("in 1 of 3 messages"));
        let (same, none) = as_neutral(&got, 1500.0, "RCOU", "small.BIN");
        assert_eq!((same, none.len()), (got, 0));
    }
}
