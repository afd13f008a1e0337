//! Device files (`--device-config FILE`) and `tetradrill devices --check`: the shipped
//! `docs/devices/*.toml` equal the built-in defaults, bad files are one line with the file and
//! line and exit status 2, and `devices --check` with nothing attached says so in one line.

use std::process::Command;

use tetradrill::device_config::{DeviceConfig, FALCON_KEYS, OMNI_KEYS, TOUCH_KEYS};
use tetradrill_tests::{refused, scratch_dir, tetradrill_bin, workspace_root};

fn shipped() -> Vec<std::path::PathBuf> {
    let dir = workspace_root().join("docs/devices");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files
}

#[test]
fn shipped_device_files_equal_the_built_in_defaults() {
    let files = shipped();
    assert!(files.iter().any(|p| p.ends_with("omni.toml")), "{files:?}");
    for f in &files {
        let c = DeviceConfig::load(f).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(c, DeviceConfig::default(), "{} drifted", f.display());
    }
}

/// Every setting of `file` (the keys its table accepts) is in the file, under a comment that
/// names one of `sources`.
fn names_every_constant_with_a_source(file: &str, keys: &[&str], sources: &[&str]) {
    let path = workspace_root().join("docs/devices").join(file);
    let text = std::fs::read_to_string(&path).unwrap();
    for key in keys {
        let at = text
            .lines()
            .position(|l| l.starts_with(&format!("{key} = ")))
            .unwrap_or_else(|| panic!("{key} is not in {}", path.display()));
        // The comment block just above the key names where the value comes from.
        let above: Vec<&str> = text.lines().take(at).collect();
        let comment: Vec<&str> = above
            .iter()
            .rev()
            .skip_while(|l| !l.starts_with('#'))
            .take_while(|l| l.starts_with('#'))
            .copied()
            .collect();
        let comment = comment.join(" ");
        let sourced = sources.iter().any(|s| comment.contains(s));
        assert!(sourced, "{file} {key}: no source in {comment:?}");
    }
}

#[test]
fn the_omni_file_names_every_constant_with_a_source() {
    let sources = ["[ROS]", "[PD]", "No public source", "Project choice"];
    names_every_constant_with_a_source("omni.toml", OMNI_KEYS, &sources);
}

#[test]
fn the_falcon_and_touch_files_name_every_constant_with_a_source() {
    let sources = ["libnifalcon", "CHAI3D", "Ours", "ours"];
    names_every_constant_with_a_source("falcon.toml", FALCON_KEYS, &sources);
    names_every_constant_with_a_source("touch.toml", TOUCH_KEYS, &sources);
}

#[test]
fn a_bad_device_file_is_one_line_with_file_line_and_key() {
    let dir = scratch_dir("devcfg", "bad");
    let f = dir.join("omni.toml");
    std::fs::write(&f, "[omni]\n# signs\nencoder_signs = [1, 1, 1]\n").unwrap();
    let path = f.to_str().unwrap();
    refused(
        &["devices", "--device-config", path],
        &[&format!("{path}:3:"), "encoder_signs"],
    );
    refused(
        &["run", "--device", "omni", "--device-config", path],
        &[&format!("{path}:3:"), "unknown key"],
    );
    let missing = dir.join("absent.toml");
    refused(
        &[
            "devices",
            "--check",
            "--device-config",
            missing.to_str().unwrap(),
        ],
        &["absent.toml", "cannot read"],
    );
}

#[test]
fn devices_check_with_nothing_attached_says_so_in_one_line() {
    let out = Command::new(tetradrill_bin())
        .args(["devices", "--check"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stdout}{stderr}");
    let found_hardware = stdout.lines().any(|l| {
        ["falcon ", "omni ", "touch "]
            .iter()
            .any(|k| l.starts_with(k))
    });
    if found_hardware {
        eprintln!(
            "note: a haptic device is attached here; the nothing-attached line is not checked"
        );
        return;
    }
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 1, "{stdout}");
    assert!(
        lines[0].starts_with("no haptic device attached"),
        "{stdout}"
    );
    assert!(lines[0].contains("no force written"), "{stdout}");
}
