//! The `[regions]` table of a scenario: one material per region label (drilling values and,
//! for a soft body, elastic values), the demo's and the tooth's.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// One region's material in a scenario's `[regions]` table.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionSpec {
    /// Newton-seconds per cubic mesh unit (0: removed at once).
    #[serde(default)]
    pub hardness: f64,
    /// Newtons the burr must press with before it removes anything.
    #[serde(default)]
    pub threshold: f64,
    /// Contact stiffness, newtons per mesh unit of depth (absent: the scenario's `stiffness`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness: Option<f64>,
    /// Display colour, `#rrggbb` (absent: the viewer's palette).
    #[serde(default, alias = "color", skip_serializing_if = "Option::is_none")]
    pub colour: Option<String>,
    /// Soft body: Young's modulus, pascal (absent: the scenario's `young`; docs/SOFT.md,
    /// "Materials per region").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub young: Option<f64>,
    /// Soft body: Poisson ratio, `0..=0.49` (absent: the scenario's `poisson`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poisson: Option<f64>,
    /// Soft body: density, kilogram per cubic metre (absent: `crate::soft::DENSITY`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density: Option<f64>,
}

impl RegionSpec {
    /// The core's material for this region.
    pub fn material(&self) -> tetradrill_core::drill::Material {
        tetradrill_core::drill::Material {
            hardness: self.hardness as f32,
            threshold: self.threshold as f32,
            stiffness: self.stiffness.unwrap_or(0.0) as f32,
        }
    }

    /// The first bad soft value (`young`, `poisson`, `density`): its key and why.
    ///
    /// # Errors
    /// A modulus or density not positive and finite (in `f32`), a Poisson ratio outside
    /// `0..=0.49`.
    pub fn soft_problem(&self) -> Result<(), (&'static str, String)> {
        let big = f32::MAX as f64;
        for (key, v) in [("young", self.young), ("density", self.density)] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0 && v < big) {
                    return Err((key, format!("must be a positive number, got {v}")));
                }
            }
        }
        if let Some(nu) = self.poisson {
            if !(0.0..=0.49).contains(&nu) {
                return Err(("poisson", format!("must be in 0..=0.49, got {nu}")));
            }
        }
        Ok(())
    }

    /// The colour as linear RGB in `0..=1`, if set.
    ///
    /// # Errors
    /// A colour that is not `#rrggbb`.
    pub fn rgb(&self) -> Result<Option<[f32; 3]>, String> {
        let Some(c) = &self.colour else {
            return Ok(None);
        };
        let hex = c.strip_prefix('#').unwrap_or(c);
        if hex.len() != 6 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(format!("colour `{c}` is not #rrggbb"));
        }
        let ch =
            |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).map_or(0.0, |v| v as f32 / 255.0);
        Ok(Some([ch(0), ch(2), ch(4)]))
    }
}

/// The demo block's materials: its shell (label 1) hard, stiff and needing a firm push; its
/// core (label 2) soft. As a soft body (`demo --soft`) the shell is a rind three times as
/// stiff as the core (3 kPa over 1 kPa, nu 0.3): chosen, not measured, so that the burr's few
/// newtons dent the 1 m block by a centimetre or two.
pub fn demo_regions() -> BTreeMap<String, RegionSpec> {
    let shell = RegionSpec {
        hardness: 300.0,
        threshold: 2.0,
        stiffness: Some(300.0),
        colour: Some("#e8dcc0".into()),
        young: Some(DEMO_SHELL_YOUNG),
        poisson: Some(0.3),
        density: None,
    };
    let core = RegionSpec {
        hardness: 120.0,
        threshold: 0.5,
        stiffness: Some(150.0),
        colour: Some("#f0c040".into()),
        young: Some(DEMO_CORE_YOUNG),
        poisson: Some(0.3),
        density: None,
    };
    BTreeMap::from([
        (tetradrill_core::builtin::BLOCK_SHELL.to_string(), shell),
        (tetradrill_core::builtin::BLOCK_CORE.to_string(), core),
    ])
}

/// Young's modulus of the demo block's shell as a soft body, pascal (chosen).
pub const DEMO_SHELL_YOUNG: f64 = 3_000.0;
/// Young's modulus of the demo block's core as a soft body, pascal (chosen).
pub const DEMO_CORE_YOUNG: f64 = 1_000.0;

/// Region label of the tooth mesh's enamel (`tests/data/meshes/models/tooth_premolar.geo`).
pub const TOOTH_ENAMEL: i32 = 1;
/// Region label of the tooth mesh's dentin.
pub const TOOTH_DENTIN: i32 = 2;
/// Region label of the tooth mesh's pulp.
pub const TOOTH_PULP: i32 = 3;

/// The tooth's materials, in metres and newtons (docs/DRILLING.md, "The tooth"): the enamel
/// five times as hard as the dentin (their Knoop hardness, 343 and 68 kg/mm^2, in Craig's
/// Restorative Dental Materials, 13th ed., Sakaguchi and Powers 2012), the pulp, soft
/// connective tissue, fifty times softer again. The contact stiffness is ordered as their
/// elastic moduli (enamel 84 GPa, dentin 18 GPa, same source; the pulp a soft tissue) at what
/// a haptic servo renders, not the tissues' own. The absolute hardness is chosen so the
/// access cavity's plunge (a 0.7 mm burr at 1.2 mm/s) presses about 3 N on the enamel and
/// about 1 N on the dentin, the range of hand forces of clinical cavity preparation.
///
/// As a soft body each tissue has its own elastic values (docs/SOFT.md, "Materials per
/// region"): Young's moduli enamel 84 GPa and dentin 18 GPa (same source), the pulp 2.07 MPa,
/// and Poisson ratios 0.33, 0.31 and 0.45, the values finite element studies of teeth take
/// (the pulp's after Farah, Craig and Sikarskie, J. Biomech. 6, 1973). Densities are left to
/// the body's default: they set the masses, not the dent under a steady press.
pub fn tooth_regions() -> BTreeMap<String, RegionSpec> {
    let enamel = RegionSpec {
        hardness: 1.0e9,
        threshold: 1.0,
        stiffness: Some(10_000.0),
        colour: Some("#f4f1e6".into()),
        young: Some(84.0e9),
        poisson: Some(0.33),
        density: None,
    };
    let dentin = RegionSpec {
        hardness: 2.0e8,
        threshold: 0.5,
        stiffness: Some(6_000.0),
        colour: Some("#e6cf95".into()),
        young: Some(18.0e9),
        poisson: Some(0.31),
        density: None,
    };
    let pulp = RegionSpec {
        hardness: 4.0e6,
        threshold: 0.1,
        stiffness: Some(1_000.0),
        colour: Some("#c8505a".into()),
        young: Some(2.07e6),
        poisson: Some(0.45),
        density: None,
    };
    BTreeMap::from([
        (TOOTH_ENAMEL.to_string(), enamel),
        (TOOTH_DENTIN.to_string(), dentin),
        (TOOTH_PULP.to_string(), pulp),
    ])
}
