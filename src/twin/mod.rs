//! The digital twin: simulates the seed-001 reference vehicle and writes synthetic inputs in
//! exactly the formats real users have, so every stage can be checked against a known truth.

pub mod cfd;
pub mod pool;
