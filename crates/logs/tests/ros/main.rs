//! Integration tests of the ROS readers and writers: round trips, damage, fuzzing, real bags.

mod bag;
mod common;
mod db3;
mod fuzz;
mod interop;
mod mcap;
mod real;
