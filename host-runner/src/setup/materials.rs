//! Materials per region: a region's drilling values, contact stiffness, colour and soft-body
//! values ([`RegionSpec`]); the demo block's and the tooth's.

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A display colour, written `#rrggbb`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Colour(pub [u8; 3]);

impl Colour {
    /// The colour `0xRRGGBB`.
    pub const fn hex(rgb: u32) -> Self {
        Self([(rgb >> 16) as u8, (rgb >> 8) as u8, rgb as u8])
    }

    /// Parses `#rrggbb` (the `#` optional).
    ///
    /// # Errors
    /// One line for anything else.
    pub fn parse(s: &str) -> Result<Self, String> {
        let hex = s.strip_prefix('#').unwrap_or(s);
        let bad = || format!("colour `{s}` is not #rrggbb");
        if hex.len() != 6 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(bad());
        }
        u32::from_str_radix(hex, 16)
            .map(Self::hex)
            .map_err(|_| bad())
    }

    /// The channels in `0..=1`.
    pub fn rgb(self) -> [f32; 3] {
        self.0.map(|c| f32::from(c) / 255.0)
    }
}

impl fmt::Display for Colour {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [r, g, b] = self.0;
        write!(f, "#{r:02x}{g:02x}{b:02x}")
    }
}

impl Serialize for Colour {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_string())
    }
}

impl<'de> Deserialize<'de> for Colour {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        Self::parse(&s).map_err(serde::de::Error::custom)
    }
}

/// One region's material (a scenario's `[regions.LABEL]` table).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionSpec {
    /// Newton-seconds per cubic mesh unit (0: removed at once).
    #[serde(default)]
    pub hardness: f64,
    /// Newtons the burr must press with before it removes anything.
    #[serde(default)]
    pub threshold: f64,
    /// Contact stiffness, newtons per mesh unit of depth (absent: the set-up's `stiffness`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness: Option<f64>,
    /// Display colour, `#rrggbb` (absent: the viewer's palette).
    #[serde(default, alias = "color", skip_serializing_if = "Option::is_none")]
    pub colour: Option<Colour>,
    /// Newtons: the burr's vibration at full cut in this region, at the set-up's
    /// `vibration_hz` (absent: none; docs/DRILLING.md, "Vibration").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vibration: Option<f64>,
    /// Specific cutting energy, joules per cubic mesh unit (newtons per square mesh unit):
    /// the region is then cut by the feed's work, not by its hardness (absent: the hardness
    /// law; docs/DRILLING.md, "Cutting resistance").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cutting_energy: Option<f64>,
    /// The friction coefficient between the spinning burr and this region: a sideways pull
    /// of this times the contact's normal force while the drill is on (absent: none;
    /// docs/DRILLING.md, "Sideways pull").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
    /// Soft body: Young's modulus, pascal (absent: the set-up's `young`; docs/SOFT.md,
    /// "Materials per region").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub young: Option<f64>,
    /// Soft body: Poisson ratio, `0..=0.49` (absent: the set-up's `poisson`).
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

    /// The core's region: [`RegionSpec::material`] with this region's vibration, cutting
    /// energy and friction (absent: none).
    pub fn region(&self) -> tetradrill_core::drill::Region {
        let f = |v: Option<f64>| v.unwrap_or(0.0) as f32;
        tetradrill_core::drill::Region::new(self.material())
            .with_vibration(f(self.vibration))
            .with_cutting_energy(f(self.cutting_energy))
            .with_friction(f(self.friction))
    }

    /// The colour in `0..=1`, if set.
    pub fn rgb(&self) -> Option<[f32; 3]> {
        self.colour.map(Colour::rgb)
    }

    /// The first bad value, as the rest of a line that starts
    /// `regions.LABEL` (`.hardness must be ...`).
    ///
    /// # Errors
    /// A negative or non-finite hardness or threshold, a stiffness, modulus or density not
    /// positive and finite (in `f32` for the soft values), a Poisson ratio outside
    /// `0..=0.49`.
    pub fn check(&self) -> Result<(), String> {
        for (what, v, ok) in [
            ("hardness", self.hardness, self.hardness >= 0.0),
            ("threshold", self.threshold, self.threshold >= 0.0),
            (
                "stiffness",
                self.stiffness.unwrap_or(1.0),
                self.stiffness.is_none_or(|k| k > 0.0),
            ),
        ] {
            if !(v.is_finite() && ok) {
                let sign = if what == "stiffness" {
                    "positive"
                } else {
                    "non-negative"
                };
                return Err(format!(".{what} must be a {sign} number, got {v}"));
            }
        }
        for (key, v) in [
            ("vibration", self.vibration),
            ("cutting_energy", self.cutting_energy),
            ("friction", self.friction),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v >= 0.0 && v < f32::MAX as f64) {
                    return Err(format!(".{key} must be a non-negative number, got {v}"));
                }
            }
        }
        let big = f32::MAX as f64;
        for (key, v) in [("young", self.young), ("density", self.density)] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0 && v < big) {
                    return Err(format!(".{key} must be a positive number, got {v}"));
                }
            }
        }
        if let Some(nu) = self.poisson {
            if !(0.0..=0.49).contains(&nu) {
                return Err(format!(".poisson must be in 0..=0.49, got {nu}"));
            }
        }
        Ok(())
    }
}

/// The demo block's materials: its shell (label 1) hard, stiff and needing a firm push; its
/// core (label 2) soft. As a soft body (`demo --soft`) the shell is a rind three times as
/// stiff as the core (3 kPa over 1 kPa, nu 0.3): chosen, not measured, so that the burr's few
/// newtons dent the 1 m block by a centimetre or two.
pub fn demo_regions() -> BTreeMap<i32, RegionSpec> {
    let shell = RegionSpec {
        hardness: 300.0,
        threshold: 2.0,
        stiffness: Some(300.0),
        colour: Some(Colour::hex(0xe8dcc0)),
        young: Some(DEMO_SHELL_YOUNG),
        poisson: Some(0.3),
        density: None,
        vibration: None,
        cutting_energy: None,
        friction: None,
    };
    let core = RegionSpec {
        hardness: 120.0,
        threshold: 0.5,
        stiffness: Some(150.0),
        colour: Some(Colour::hex(0xf0c040)),
        young: Some(DEMO_CORE_YOUNG),
        poisson: Some(0.3),
        density: None,
        vibration: None,
        cutting_energy: None,
        friction: None,
    };
    BTreeMap::from([
        (tetradrill_core::builtin::BLOCK_SHELL, shell),
        (tetradrill_core::builtin::BLOCK_CORE, core),
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
pub fn tooth_regions() -> BTreeMap<i32, RegionSpec> {
    let enamel = RegionSpec {
        hardness: 1.0e9,
        threshold: 1.0,
        stiffness: Some(10_000.0),
        colour: Some(Colour::hex(0xf4f1e6)),
        young: Some(84.0e9),
        poisson: Some(0.33),
        density: None,
        vibration: None,
        cutting_energy: None,
        friction: None,
    };
    let dentin = RegionSpec {
        hardness: 2.0e8,
        threshold: 0.5,
        stiffness: Some(6_000.0),
        colour: Some(Colour::hex(0xe6cf95)),
        young: Some(18.0e9),
        poisson: Some(0.31),
        density: None,
        vibration: None,
        cutting_energy: None,
        friction: None,
    };
    let pulp = RegionSpec {
        hardness: 4.0e6,
        threshold: 0.1,
        stiffness: Some(1_000.0),
        colour: Some(Colour::hex(0xc8505a)),
        young: Some(2.07e6),
        poisson: Some(0.45),
        density: None,
        vibration: None,
        cutting_energy: None,
        friction: None,
    };
    BTreeMap::from([
        (TOOTH_ENAMEL, enamel),
        (TOOTH_DENTIN, dentin),
        (TOOTH_PULP, pulp),
    ])
}
