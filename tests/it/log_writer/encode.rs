//! The log writer's encoders: each stream's rows as ROS messages (bag, MCAP with ROS 2 or
//! ROS 1 messages, `.db3`) or as DataFlash records, through the log crate's writers.

use super::{EPOCH_S, Row, Stream, df_name};
use anyhow::Context;
use hydrofit_logs::write::{self, BagWriter, Db3Writer, McapWriter};
use hydrofit_logs::{LogError, Schema, Value};
use std::path::Path;

/// A ROS message of `schema` with `numbers` at `fields` and the header stamped at `t`.
fn ros_message(schema: &Schema, s: &Stream, r: &Row) -> anyhow::Result<Value> {
    let mut v = write::zero(schema);
    if schema.has_header() {
        write::set(schema, &mut v, "header.stamp", EPOCH_S + r.t).map_err(anyhow::Error::msg)?;
    }
    if s.ros_type.ends_with("MultiArray") {
        write::set_array(schema, &mut v, "data", &r.numbers).map_err(anyhow::Error::msg)?;
        return Ok(v);
    }
    for (f, x) in s.ros_fields.iter().zip(&r.numbers) {
        write::set(schema, &mut v, f, *x).map_err(anyhow::Error::msg)?;
    }
    Ok(v)
}

/// What the twin needs of a ROS writer (bag, MCAP or `.db3`): topics of built-in types,
/// their layouts, and messages.
pub(super) trait RosWriter {
    type Id: Copy;
    fn topic(&mut self, topic: &str, type_name: &str) -> Result<Self::Id, LogError>;
    fn layout(&self, id: Self::Id) -> Option<&Schema>;
    fn put(&mut self, id: Self::Id, time_s: f64, value: &Value) -> Result<(), LogError>;
}

macro_rules! ros_writer {
    ($w:ty, $id:ty) => {
        impl RosWriter for $w {
            type Id = $id;
            fn topic(&mut self, topic: &str, type_name: &str) -> Result<$id, LogError> {
                self.add_topic(topic, type_name)
            }
            fn layout(&self, id: $id) -> Option<&Schema> {
                self.schema(id)
            }
            fn put(&mut self, id: $id, time_s: f64, value: &Value) -> Result<(), LogError> {
                self.write(id, time_s, value)
            }
        }
    };
}

/// An MCAP writer whose topics carry ROS 1 messages.
pub(super) struct Ros1Mcap(pub(super) McapWriter);

impl RosWriter for Ros1Mcap {
    type Id = u16;
    fn topic(&mut self, topic: &str, type_name: &str) -> Result<u16, LogError> {
        self.0.add_ros1_topic(topic, type_name)
    }
    fn layout(&self, id: u16) -> Option<&Schema> {
        self.0.schema(id)
    }
    fn put(&mut self, id: u16, time_s: f64, value: &Value) -> Result<(), LogError> {
        self.0.write(id, time_s, value)
    }
}

ros_writer!(BagWriter, u32);
ros_writer!(McapWriter, u16);
ros_writer!(Db3Writer, i64);

/// Writes every stream's rows through `w` (the caller finishes the file).
pub(super) fn write_ros<W: RosWriter>(
    w: &mut W,
    streams: &[Stream],
    rows: &[Row],
) -> anyhow::Result<()> {
    let mut ids = Vec::new();
    for s in streams {
        ids.push((s.name, w.topic(s.ros_topic, s.ros_type)?, s));
    }
    for r in rows {
        let (_, id, s) = ids
            .iter()
            .find(|(n, _, _)| *n == r.stream)
            .context("a stream")?;
        let schema = w.layout(*id).context("a schema")?.clone();
        w.put(*id, EPOCH_S + r.t, &ros_message(&schema, s, r)?)?;
    }
    Ok(())
}

pub(super) fn write_dataflash(path: &Path, streams: &[Stream], rows: &[Row]) -> anyhow::Result<()> {
    let mut w = hydrofit_logs::dataflash::Writer::new();
    for s in streams {
        // TimeUS, then doubles: the log holds the CSV's numbers exactly.
        let format = format!("Q{}", "d".repeat(s.df_labels.len()));
        let labels = std::iter::once("TimeUS".to_string())
            .chain(s.df_labels.iter().cloned())
            .collect::<Vec<_>>()
            .join(",");
        w.define(df_name(s.name), &format, &labels)
            .map_err(anyhow::Error::msg)?;
    }
    for r in rows {
        let mut values = vec![Value::UInt((r.t * 1e6).round() as u64)];
        values.extend(r.numbers.iter().map(|x| Value::Float(*x)));
        w.write(df_name(r.stream), &values)
            .map_err(anyhow::Error::msg)?;
    }
    std::fs::write(path, w.into_bytes())?;
    Ok(())
}
