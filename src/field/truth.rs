//! The known truth of a twin's field runs, read from its `name,value[,unit]` tables, for the
//! reports to set identified parameters beside.

use std::collections::BTreeMap;

/// Truth values by name from the truth files' `name,value[,unit]` tables (the twins'
/// `transfer.csv` and `parameters.csv`), when there are any.
pub type Truth = BTreeMap<String, f64>;

/// Reads every `name,value` row of the truth CSVs among `files` (under `root`).
pub fn read_truth(root: &std::path::Path, files: &[String]) -> Truth {
    let mut out = Truth::new();
    for f in files {
        let Ok(text) = std::fs::read_to_string(root.join(f)) else {
            continue;
        };
        let mut lines = text.lines();
        if !lines.next().is_some_and(|h| h.starts_with("name,value")) {
            continue;
        }
        for l in lines {
            let mut it = l.split(',');
            if let (Some(n), Some(v)) = (it.next(), it.next())
                && let Ok(v) = v.trim().parse::<f64>()
            {
                out.insert(n.trim().to_string(), v);
            }
        }
    }
    out
}
