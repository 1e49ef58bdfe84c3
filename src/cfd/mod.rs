//! CFD runs: STAR-CCM+ exports read, OpenFOAM cases written, run (here or on a Slurm
//! cluster) and read, each turned into a response table (a force applied, the motion recorded).

pub mod openfoam;
pub mod slurm;
pub mod starccm;
