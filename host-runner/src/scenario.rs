//! Scenarios: everything a run needs to know (mesh, tool, trace, stiffness, drilling limits,
//! capacities), with defaults in one place. A scenario comes from the defaults, then a TOML
//! file or a `builtin:NAME`, then the command-line flags, each overriding the one before.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::CliError;

/// Which way depth finds the surface intersections of border edges.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum DepthMethod {
    /// Walk the border edge through the tets to a boundary face (seed 000).
    Traced,
    /// Hash the boundary faces and query them with the edge (Heidelberger 2004).
    Hashed,
}

/// A complete scenario. Field names are the TOML keys and match the flags.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scenario {
    /// Mesh file, or `builtin:cube12` / `builtin:block:N` (the unit cube `[-0.5, 0.5]^3`).
    pub mesh: String,
    /// Factor applied to the mesh's coordinates.
    pub scale: f64,
    /// Trace CSV file, or `builtin:demo`; positions in mesh units after `scale`.
    pub trace: String,
    /// `sphere:R` (a spherical burr of radius R) or `mesh:FILE` (a tet-mesh tool, tip at the
    /// origin, axis +z).
    pub tool: String,
    /// Factor applied to a mesh tool's coordinates.
    pub tool_scale: f64,
    /// Newtons per mesh unit of penetration depth.
    pub stiffness: f64,
    /// Newton-seconds per mesh unit.
    pub damping: f64,
    /// Force clamp, newtons.
    pub max_force: f64,
    /// Depth method for a mesh tool.
    pub depth_method: DepthMethod,
    /// Deepest subdivision level of a drilled tet.
    pub max_depth: u8,
    /// Refinement stops below this face area (mesh units squared).
    pub min_area: f64,
    /// Hierarchy nodes available for drilling.
    pub hierarchy_capacity: usize,
    /// Work units of erosion per servo tick; the rest is carried to later ticks.
    pub budget_per_tick: u32,
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            mesh: "builtin:block:8".into(),
            scale: 1.0,
            trace: "builtin:demo".into(),
            tool: "sphere:0.1".into(),
            tool_scale: 1.0,
            stiffness: 200.0,
            damping: 0.5,
            max_force: 8.0,
            depth_method: DepthMethod::Traced,
            max_depth: 5,
            min_area: 0.0,
            hierarchy_capacity: 1 << 20,
            budget_per_tick: 4000,
        }
    }
}

/// The scenario flags shared by `demo`, `run` and `replay`; each overrides the scenario.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct ScenarioFlags {
    /// A scenario file (TOML, keys as these flags with `_` for `-`) or `builtin:demo`,
    /// `builtin:firmware`.
    #[arg(long)]
    pub scenario: Option<String>,
    /// Mesh file or `builtin:cube12`, `builtin:block:N`.
    #[arg(long)]
    pub mesh: Option<String>,
    /// Scale the mesh's coordinates.
    #[arg(long, value_parser = positive)]
    pub scale: Option<f64>,
    /// Trace CSV (`t,x,y,z,qw,qx,qy,qz,buttons`) or `builtin:demo`.
    #[arg(long)]
    pub trace: Option<String>,
    /// `sphere:R` or `mesh:FILE`.
    #[arg(long)]
    pub tool: Option<String>,
    /// Scale a mesh tool's coordinates.
    #[arg(long, value_parser = positive)]
    pub tool_scale: Option<f64>,
    /// Stiffness, newtons per mesh unit of depth.
    #[arg(long, value_parser = positive)]
    pub stiffness: Option<f64>,
    /// Damping, newton-seconds per mesh unit.
    #[arg(long, value_parser = non_negative)]
    pub damping: Option<f64>,
    /// Force clamp, newtons.
    #[arg(long, value_parser = positive)]
    pub max_force: Option<f64>,
    /// Depth method for a mesh tool.
    #[arg(long, value_enum)]
    pub depth_method: Option<DepthMethod>,
    /// Deepest subdivision level (1..=9).
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..=9))]
    pub max_depth: Option<u8>,
    /// Smallest face area refined (mesh units squared).
    #[arg(long, value_parser = non_negative)]
    pub min_area: Option<f64>,
    /// Hierarchy nodes available.
    #[arg(long, value_parser = clap::value_parser!(usize))]
    pub hierarchy_capacity: Option<usize>,
    /// Work units of erosion per tick.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub budget_per_tick: Option<u32>,
}

fn positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{s}` is not a positive number")),
    }
}

fn non_negative(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("`{s}` is not a non-negative number")),
    }
}

/// A built-in scenario by name.
pub fn builtin(name: &str) -> Option<Scenario> {
    match name {
        "demo" => Some(Scenario::default()),
        // Small enough for the Cortex-M4 firmware's static storage; same path as the demo.
        "firmware" => Some(Scenario {
            mesh: "builtin:block:4".into(),
            max_depth: 4,
            hierarchy_capacity: 20_000,
            budget_per_tick: 600,
            ..Scenario::default()
        }),
        _ => None,
    }
}

impl Scenario {
    /// Loads `builtin:NAME` or a TOML file. Unknown keys and bad values exit 2 naming the
    /// file and line.
    pub fn load(spec: &str) -> Result<Self, CliError> {
        if let Some(name) = spec.strip_prefix("builtin:") {
            return builtin(name).ok_or_else(|| {
                CliError::input(format!(
                    "unknown scenario `{spec}` (built-in: builtin:demo, builtin:firmware)"
                ))
            });
        }
        let path = Path::new(spec);
        let text = std::fs::read_to_string(path)
            .map_err(|e| CliError::at(path, None, format!("cannot read scenario: {e}")))?;
        let sc: Scenario = toml::from_str(&text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            CliError::at(path, line, e.message().replace('\n', " "))
        })?;
        sc.check().map_err(|m| CliError::at(path, None, m))?;
        Ok(sc)
    }

    /// Applies the scenario flags: first `--scenario`, then each flag given.
    pub fn from_flags(f: &ScenarioFlags) -> Result<Self, CliError> {
        let mut s = match &f.scenario {
            Some(spec) => Self::load(spec)?,
            None => Self::default(),
        };
        macro_rules! take {
            ($($field:ident),*) => { $( if let Some(v) = &f.$field { s.$field = v.clone(); } )* };
        }
        take!(mesh, scale, trace, tool, tool_scale, stiffness, damping, max_force);
        take!(
            depth_method,
            max_depth,
            min_area,
            hierarchy_capacity,
            budget_per_tick
        );
        s.check().map_err(CliError::input)?;
        Ok(s)
    }

    /// Values no flag parser can refuse on its own (a scenario file sets them directly).
    pub fn check(&self) -> Result<(), String> {
        let pos = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be a positive number, got {v}"))
            }
        };
        pos("scale", self.scale)?;
        pos("tool_scale", self.tool_scale)?;
        pos("stiffness", self.stiffness)?;
        pos("max_force", self.max_force)?;
        if !(self.damping.is_finite() && self.damping >= 0.0) {
            return Err(format!(
                "damping must be non-negative, got {}",
                self.damping
            ));
        }
        if !(self.min_area.is_finite() && self.min_area >= 0.0) {
            return Err(format!(
                "min_area must be non-negative, got {}",
                self.min_area
            ));
        }
        if !(1..=9).contains(&self.max_depth) {
            return Err(format!("max_depth must be 1..=9, got {}", self.max_depth));
        }
        if self.budget_per_tick == 0 {
            return Err("budget_per_tick must be at least 1".into());
        }
        self.tool_kind()?;
        Ok(())
    }

    /// The tool as parsed from `tool`.
    pub fn tool_kind(&self) -> Result<ToolKind, String> {
        if let Some(r) = self.tool.strip_prefix("sphere:") {
            match r.parse::<f64>() {
                Ok(r) if r.is_finite() && r > 0.0 => Ok(ToolKind::Sphere(r)),
                _ => Err(format!(
                    "tool `{}`: the radius must be a positive number",
                    self.tool
                )),
            }
        } else if let Some(file) = self.tool.strip_prefix("mesh:") {
            if file.is_empty() {
                Err("tool `mesh:` needs a file".into())
            } else {
                Ok(ToolKind::Mesh(PathBuf::from(file)))
            }
        } else {
            Err(format!(
                "tool `{}`: expected sphere:R or mesh:FILE",
                self.tool
            ))
        }
    }
}

/// The tool of a scenario.
#[derive(Debug, Clone, PartialEq)]
pub enum ToolKind {
    /// A spherical burr of this radius (mesh units).
    Sphere(f64),
    /// A tet-mesh tool from this file.
    Mesh(PathBuf),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_override_the_scenario() {
        let f = ScenarioFlags {
            scenario: Some("builtin:firmware".into()),
            stiffness: Some(50.0),
            ..Default::default()
        };
        let s = Scenario::from_flags(&f).expect("valid");
        assert_eq!(s.mesh, "builtin:block:4");
        assert_eq!(s.stiffness, 50.0);
    }

    #[test]
    fn bad_scenarios_name_the_file_and_line() {
        let dir = std::env::temp_dir().join(format!("tdscn-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let p = dir.join("bad.toml");
        std::fs::write(&p, "mesh = \"builtin:cube12\"\nstiffnes = 3.0\n").expect("write");
        let e = Scenario::load(p.to_str().expect("utf8")).expect_err("unknown key");
        assert_eq!(e.code, 2);
        assert!(e.message.contains("bad.toml:2:"), "{}", e.message);
        std::fs::write(&p, "tool = \"sphere:-1\"\n").expect("write");
        let e = Scenario::load(p.to_str().expect("utf8")).expect_err("negative radius");
        assert!(e.message.contains("radius"), "{}", e.message);
        assert!(Scenario::load("builtin:nope").is_err());
    }
}
