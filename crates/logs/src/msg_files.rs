//! ROS 2 message definitions read from `.msg` files, for a `.db3` bag of ROS 2 Humble or older
//! (which carries no definitions) whose topics are of a type hydrofit has none built in for: a
//! vehicle's own messages, `px4_msgs`, a DVL driver's. Type `pkg/msg/Type` is the file
//! `pkg/msg/Type.msg` (the layout of every ROS 2 package, in a workspace's `src/` as in an
//! installation's `share/`) under one of the folders searched, in this order:
//! - the folders the user names (run.yaml's `log: {message_folders: [...]}`, `hydrofit inspect
//!   --msg-folder`);
//! - `share/` of every prefix in `AMENT_PREFIX_PATH` (a sourced ROS 2 installation or workspace);
//! - near the bag: its own folder and the three above it, each with its subfolders (a
//!   `types/` folder beside the bags, a workspace's `src/`).
//!
//! A folder may also be a package (`px4_msgs/`, holding `msg/`) or its `msg/` folder. The
//! text is put together as rosbag2 stores it since Iron and as the bag's own definitions are
//! read ([`crate::msgdef`]): the type's lines, then each type it uses after a line of `=` and
//! `MSG: pkg/msg/Type`; a type found in no file is taken from the built-in definitions
//! ([`crate::ros_types`]).

use crate::msgdef::{Flavor, short_name, used_types};
use crate::ros_types;
use std::path::{Path, PathBuf};

/// How many folders above the bag's own are searched.
const UP: usize = 3;

/// A type's definition text and the files it was read from (inputs of what is decoded).
#[derive(Debug, Clone, PartialEq)]
pub struct Found {
    pub text: String,
    pub files: Vec<PathBuf>,
}

/// The folders searched for the types of the bag at `bag`: `user`'s first, then the ROS 2
/// environment's, then the bag's own and those above it.
pub fn search_folders(bag: &Path, user: &[PathBuf]) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = user.to_vec();
    if let Some(prefixes) = std::env::var_os("AMENT_PREFIX_PATH") {
        out.extend(std::env::split_paths(&prefixes).map(|p| p.join("share")));
    }
    let start = if bag.is_dir() {
        Some(bag)
    } else {
        bag.parent()
    };
    out.extend(
        start
            .into_iter()
            .flat_map(Path::ancestors)
            .filter(|p| !p.as_os_str().is_empty())
            .take(UP + 1)
            .map(Path::to_path_buf),
    );
    out.dedup();
    out
}

/// The file of `pkg/Type` under `folder`, if there is one.
fn file_in(folder: &Path, pkg: &str, ty: &str) -> Option<PathBuf> {
    let file = format!("{ty}.msg");
    let name = folder.file_name().map(|n| n.to_string_lossy().into_owned());
    let parent = folder
        .parent()
        .and_then(Path::file_name)
        .map(|n| n.to_string_lossy().into_owned());
    let mut candidates = vec![folder.join(pkg).join("msg").join(&file)];
    if name.as_deref() == Some(pkg) {
        candidates.push(folder.join("msg").join(&file));
    }
    if name.as_deref() == Some("msg") && parent.as_deref() == Some(pkg) {
        candidates.push(folder.join(&file));
    }
    if let Some(found) = candidates.into_iter().find(|c| c.is_file()) {
        return Some(found);
    }
    let mut subs: Vec<PathBuf> = std::fs::read_dir(folder)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    subs.sort();
    subs.into_iter()
        .map(|s| s.join(pkg).join("msg").join(&file))
        .find(|c| c.is_file())
}

/// The `.msg` file of `type_name` (`pkg/msg/Type` or `pkg/Type`) in the first of `folders`
/// that has it.
pub fn find(type_name: &str, folders: &[PathBuf]) -> Option<PathBuf> {
    let short = short_name(type_name);
    let (pkg, ty) = short.split_once('/')?;
    folders.iter().find_map(|f| file_in(f, pkg, ty))
}

/// The definition of `type_name` from `.msg` files under `folders`, with every type it uses:
/// `Ok(None)` when the type itself is in none of them, `Err` when a file cannot be read or a
/// type it uses is neither in a file nor built in.
pub fn definition(type_name: &str, folders: &[PathBuf]) -> Result<Option<Found>, String> {
    let main = short_name(type_name);
    let Some(file) = find(&main, folders) else {
        return Ok(None);
    };
    let mut found = Found {
        text: read(&file)?,
        files: vec![file],
    };
    let mut done = vec![main.clone()];
    let mut queue: std::collections::VecDeque<String> = uses(&found.text, &main)?.into();
    while let Some(dep) = queue.pop_front() {
        if done.contains(&dep) {
            continue;
        }
        done.push(dep.clone());
        let own = match find(&dep, folders) {
            Some(f) => {
                let text = read(&f)?;
                found.files.push(f);
                text
            }
            None => ros_types::ros2_own(&dep).ok_or_else(|| {
                format!("`{main}` uses `{dep}`, which is in no .msg file searched and not built in")
            })?,
        };
        queue.extend(uses(&own, &dep)?);
        let shown = ros_types::ros2_name(&dep);
        found
            .text
            .push_str(&format!("\n{}\nMSG: {shown}\n{own}", "=".repeat(80)));
    }
    Ok(Some(found))
}

/// The non-primitive types `text` (the lines of type `of`, `pkg/Type`) uses, as `pkg/Type`,
/// in order of use.
fn uses(text: &str, of: &str) -> Result<Vec<String>, String> {
    let pkg = of.split_once('/').map_or("", |p| p.0);
    let used = used_types(text, Flavor::Ros2).map_err(|e| format!("`{of}`: {e}"))?;
    Ok(used
        .into_iter()
        .map(|t| match t.contains('/') {
            true => short_name(&t),
            false => format!("{pkg}/{t}"),
        })
        .collect())
}

fn read(file: &Path) -> Result<String, String> {
    std::fs::read_to_string(file).map_err(|e| format!("{}: {e}", file.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgdef::schema;
    use crate::value::{Kind, Leaf};

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("hydrofit-msg-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// A vehicle's own type beside the bags (`types/<pkg>/msg/`), using a type of its own
    /// package by its bare name and a built-in one, with constants written `NAME = value`
    /// as px4_msgs writes them.
    #[test]
    fn a_type_beside_the_bags_is_read_with_what_it_uses() {
        let d = scratch("beside");
        let msg = d.join("types/rov_msgs/msg");
        std::fs::create_dir_all(&msg).unwrap();
        std::fs::write(
            msg.join("Thrust.msg"),
            "# thrusters\nuint8 MODE_RAW = 0  # raw\nstd_msgs/Header header\n\
             float32[6] pwm  # [us]\nGains gains\ngeometry_msgs/Vector3 force\n",
        )
        .unwrap();
        std::fs::write(msg.join("Gains.msg"), "float64 kp 1.0\nfloat64 kd\n").unwrap();
        let bag = d.join("bags/run1");
        std::fs::create_dir_all(&bag).unwrap();
        let folders = search_folders(&bag.join("run1_0.db3"), &[]);
        let found = definition("rov_msgs/msg/Thrust", &folders)
            .unwrap()
            .unwrap();
        assert_eq!(found.files.len(), 2, "{:?}", found.files);
        let s = schema(&found.text, "rov_msgs/msg/Thrust", Flavor::Ros2).unwrap();
        let names: Vec<&str> = s.fields.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["header", "pwm", "gains", "force"]);
        assert!(s.has_header());
        match &s.fields[1].kind {
            Kind::Array(leaf, Some(6)) => assert!(matches!(**leaf, Kind::Leaf(Leaf::F32))),
            k => panic!("pwm is {k:?}"),
        }
        assert!(
            definition("rov_msgs/msg/Other", &folders)
                .unwrap()
                .is_none()
        );
        std::fs::remove_dir_all(d).unwrap();
    }

    /// A type whose dependency is nowhere is refused by name; the user's folder comes first
    /// and may be the package itself or its `msg/` folder.
    #[test]
    fn a_missing_dependency_is_named_and_the_users_folder_comes_first() {
        let d = scratch("missing");
        let pkg = d.join("mine/rov_msgs/msg");
        std::fs::create_dir_all(&pkg).unwrap();
        std::fs::write(pkg.join("State.msg"), "Extra e\n").unwrap();
        let e = definition("rov_msgs/State", &[d.join("mine/rov_msgs")]).unwrap_err();
        assert!(e.contains("rov_msgs/Extra"), "{e}");
        std::fs::write(pkg.join("Extra.msg"), "int16 x\n").unwrap();
        for folder in [d.join("mine/rov_msgs"), pkg.clone(), d.join("mine")] {
            let found = definition("rov_msgs/State", std::slice::from_ref(&folder)).unwrap();
            assert!(found.is_some(), "{}", folder.display());
        }
        std::fs::remove_dir_all(d).unwrap();
    }
}
