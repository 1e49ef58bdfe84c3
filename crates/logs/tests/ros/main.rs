//! Integration tests of the ROS readers and writers: round trips, damage, fuzzing, real bags.

mod bag;
mod common;
mod fuzz;
mod interop;
mod mcap;
mod real;
