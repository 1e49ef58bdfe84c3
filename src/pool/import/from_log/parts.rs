//! A signal spread over several topics, one part each (a simulator publishes each thruster's
//! command on its own topic): the parts' messages merged into one sample per message, each
//! part's latest value held until its next, from the first time every part has one. Messages
//! of one update cycle (within [`SAME_CYCLE_S`] of the cycle's first) make one sample: six
//! thrusters published microseconds apart are one command, not six samples a few microseconds
//! apart that would read as a bursty log.

/// Messages closer than this to the first of their cycle are one sample, s.
const SAME_CYCLE_S: f64 = 1e-3;

/// One message of one part: its time (s from the span's start), the part and its values.
pub struct Piece {
    pub t: f64,
    pub part: usize,
    pub row: Vec<f64>,
}

/// The merged samples of `parts` parts: at each message's time, every part's latest values in
/// part order; none before every part has spoken.
pub fn merged(mut pieces: Vec<Piece>, parts: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
    pieces.sort_by(|a, b| a.t.total_cmp(&b.t));
    let mut latest: Vec<Option<Vec<f64>>> = vec![None; parts];
    let (mut t, mut rows): (Vec<f64>, Vec<Vec<f64>>) = (Vec::new(), Vec::new());
    for p in pieces {
        let at = p.t;
        if let Some(slot) = latest.get_mut(p.part) {
            *slot = Some(p.row);
        }
        if latest.iter().all(Option::is_some) {
            let row: Vec<f64> = latest.iter().flatten().flatten().copied().collect();
            // Parts that speak in one cycle make one sample, at the cycle's first time, with
            // all their values.
            if t.last().is_some_and(|&first| at - first < SAME_CYCLE_S) {
                *rows.last_mut().expect("a row for each time") = row;
            } else {
                t.push(at);
                rows.push(row);
            }
        }
    }
    (t, rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_are_held_and_merged_from_when_all_have_spoken() {
        let p = |t: f64, part: usize, x: f64| Piece {
            t,
            part,
            row: vec![x],
        };
        // Part 1 speaks first; part 0 joins at 0.1 s; both at 0.2 s (0.4 ms apart: one
        // cycle); part 1 alone at 0.25 s.
        let pieces = vec![
            p(0.0, 1, 10.0),
            p(0.2, 1, 12.0),
            p(0.1, 0, 1.0),
            p(0.2004, 0, 2.0),
            p(0.25, 1, 13.0),
        ];
        let (t, rows) = merged(pieces, 2);
        assert_eq!(t, [0.1, 0.2, 0.25]);
        assert_eq!(rows, [vec![1.0, 10.0], vec![2.0, 12.0], vec![2.0, 13.0]]);
        // A part that never speaks: no sample.
        assert!(merged(vec![p(0.0, 0, 1.0)], 2).0.is_empty());
    }
}
