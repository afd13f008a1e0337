//! Scripted tool paths shared by the host and the firmware: a path is a list of key poses
//! interpolated linearly in f32, so both sides compute the same positions bit for bit.
//!
//! ```
//! use tetradrill_core::script::{Key, Script, DEMO, DRILL_ON};
//! use tetradrill_core::Vec3;
//!
//! // The demo comes down from above the block's top face with the drill off ...
//! assert_eq!(DEMO.at(0), (Vec3::new(0.0, 0.0, 0.9), 0));
//! let (halfway, buttons) = DEMO.at(200);
//! assert!((halfway.z - 0.76).abs() < 1e-6 && buttons & DRILL_ON == 0);
//! // ... and plunges with it on from tick 400; 6,001 ticks in all (6 s at 1 kHz).
//! assert_eq!(DEMO.at(400), (Vec3::new(0.0, 0.0, 0.62), DRILL_ON));
//! assert_eq!(DEMO.ticks(), 6001);
//!
//! // A path of one's own: positions in between are interpolated, the ends held.
//! let keys = [
//!     Key { tick: 0, position: Vec3::ZERO, buttons: 0 },
//!     Key { tick: 10, position: Vec3::X, buttons: 0 },
//! ];
//! let path = Script { keys: &keys };
//! assert_eq!((path.at(5).0, path.at(99).0), (Vec3::new(0.5, 0.0, 0.0), Vec3::X));
//! ```

use glam::Vec3;

/// One key pose of a scripted path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Key {
    /// Servo tick at which the tool is at `position`.
    pub tick: u32,
    /// Tool position (sphere centre or tool tip), mesh units.
    pub position: Vec3,
    /// Button mask from this key to the next (bit 0 = drill on).
    pub buttons: u32,
}

/// A path through key poses.
#[derive(Clone, Copy, Debug)]
pub struct Script<'a> {
    /// Keys in increasing tick order; the first key's tick should be 0.
    pub keys: &'a [Key],
}

/// The drill-on bit of a button mask.
pub const DRILL_ON: u32 = 1;

/// The demo's path over the unit block `[-0.5, 0.5]^3` (top face `z = 0.5`): approach from
/// above, plunge with the drill on, drag along x and back, retract. 1 kHz ticks, 6 s.
pub(crate) const DEMO_KEYS: [Key; 7] = [
    Key {
        tick: 0,
        position: Vec3::new(0.0, 0.0, 0.9),
        buttons: 0,
    },
    Key {
        tick: 400,
        position: Vec3::new(0.0, 0.0, 0.62),
        buttons: DRILL_ON,
    },
    Key {
        tick: 1800,
        position: Vec3::new(0.0, 0.0, 0.25),
        buttons: DRILL_ON,
    },
    Key {
        tick: 3300,
        position: Vec3::new(0.3, 0.1, 0.25),
        buttons: DRILL_ON,
    },
    Key {
        tick: 4800,
        position: Vec3::new(-0.2, -0.2, 0.3),
        buttons: DRILL_ON,
    },
    Key {
        tick: 5400,
        position: Vec3::new(-0.2, -0.2, 0.9),
        buttons: 0,
    },
    Key {
        tick: 6000,
        position: Vec3::new(-0.2, -0.2, 0.9),
        buttons: 0,
    },
];

/// An access cavity in the premolar of `tests/data/meshes/models/tooth_premolar_gmsh.msh22.msh`
/// (metres, long axis +z, occlusal fissure at `z = 0.0216` along `x`): a 0.7 mm burr comes
/// down on the fissure and plunges 2.9 mm at about 0.5 mm/s with the drill on (through the
/// enamel, 1.1 mm here, into the dentin), sweeps 1 mm mesially and distally along the fissure
/// and back, deepens 1.2 mm until it opens the pulp chamber's roof, and is withdrawn. 1 kHz
/// ticks, 17.6 s.
pub(crate) const TOOTH_ACCESS_KEYS: [Key; 9] = [
    Key {
        tick: 0,
        position: Vec3::new(0.0, 0.0, 0.0235),
        buttons: 0,
    },
    Key {
        tick: 500,
        position: Vec3::new(0.0, 0.0, 0.0225),
        buttons: DRILL_ON,
    },
    Key {
        tick: 6000,
        position: Vec3::new(0.0, 0.0, 0.0196),
        buttons: DRILL_ON,
    },
    Key {
        tick: 8000,
        position: Vec3::new(0.001, 0.0, 0.0196),
        buttons: DRILL_ON,
    },
    Key {
        tick: 12000,
        position: Vec3::new(-0.001, 0.0, 0.0196),
        buttons: DRILL_ON,
    },
    Key {
        tick: 14000,
        position: Vec3::new(0.0, 0.0, 0.0196),
        buttons: DRILL_ON,
    },
    Key {
        tick: 16400,
        position: Vec3::new(0.0, 0.0, 0.0184),
        buttons: DRILL_ON,
    },
    Key {
        tick: 17400,
        position: Vec3::new(0.0, 0.0, 0.0235),
        buttons: 0,
    },
    Key {
        tick: 17600,
        position: Vec3::new(0.0, 0.0, 0.0235),
        buttons: 0,
    },
];

/// An access cavity in the real-size premolar of
/// `tests/data/meshes/models/premolar_gmsh.msh22.msh` (metres, long axis +z, buccal +y, the
/// central fissure along x at `z = 0.02075`, the enamel under it down to `z = 0.0195`, the pulp
/// chamber's roof at `z = 0.01745` and its horns at `y = +-0.0013` up to `z = 0.01855`), for a
/// burr of radius 0.7 mm: it comes down on the fissure and plunges 2.9 mm at 0.5 mm/s with the
/// drill on (through the enamel into the dentin), widens the cavity 1.2 mm buccally and
/// lingually and back (an access cavity is oval bucco-lingually), deepens 1.7 mm at 0.5 mm/s
/// into the pulp chamber, unroofs it 0.8 mm each way towards the horns, and is withdrawn
/// (the drill on, as a burr leaves the cavity it cut). 1 kHz ticks, 27 s.
pub(crate) const PREMOLAR_ACCESS_KEYS: [Key; 12] = [
    Key {
        tick: 0,
        position: Vec3::new(0.0, 0.0, 0.024),
        buttons: 0,
    },
    Key {
        tick: 500,
        position: Vec3::new(0.0, 0.0, 0.0225),
        buttons: DRILL_ON,
    },
    Key {
        tick: 6300,
        position: Vec3::new(0.0, 0.0, 0.0196),
        buttons: DRILL_ON,
    },
    Key {
        tick: 8700,
        position: Vec3::new(0.0, 0.0012, 0.0196),
        buttons: DRILL_ON,
    },
    Key {
        tick: 13500,
        position: Vec3::new(0.0, -0.0012, 0.0196),
        buttons: DRILL_ON,
    },
    Key {
        tick: 15900,
        position: Vec3::new(0.0, 0.0, 0.0196),
        buttons: DRILL_ON,
    },
    Key {
        tick: 19300,
        position: Vec3::new(0.0, 0.0, 0.0179),
        buttons: DRILL_ON,
    },
    Key {
        tick: 20900,
        position: Vec3::new(0.0, 0.0008, 0.0179),
        buttons: DRILL_ON,
    },
    Key {
        tick: 24100,
        position: Vec3::new(0.0, -0.0008, 0.0179),
        buttons: DRILL_ON,
    },
    Key {
        tick: 25700,
        position: Vec3::new(0.0, 0.0, 0.0179),
        buttons: DRILL_ON,
    },
    Key {
        tick: 26700,
        position: Vec3::new(0.0, 0.0, 0.024),
        buttons: 0,
    },
    Key {
        tick: 27000,
        position: Vec3::new(0.0, 0.0, 0.024),
        buttons: 0,
    },
];

impl Script<'_> {
    /// Number of ticks the path lasts (the last key's tick + 1).
    pub fn ticks(&self) -> u32 {
        self.keys.last().map_or(0, |k| k.tick + 1)
    }

    /// Position and buttons at `tick` (held at the ends).
    ///
    /// # Bounded work
    /// O(keys).
    pub fn at(&self, tick: u32) -> (Vec3, u32) {
        let Some(first) = self.keys.first() else {
            return (Vec3::ZERO, 0);
        };
        if tick <= first.tick {
            return (first.position, first.buttons);
        }
        for w in self.keys.windows(2) {
            let (a, b) = (w[0], w[1]);
            if tick < b.tick {
                let span = (b.tick - a.tick) as f32;
                let u = (tick - a.tick) as f32 / span;
                return (a.position + (b.position - a.position) * u, a.buttons);
            }
        }
        let last = self.keys[self.keys.len() - 1];
        (last.position, last.buttons)
    }
}

/// The demo script.
pub const DEMO: Script<'static> = Script { keys: &DEMO_KEYS };

/// The tooth's access cavity (`TOOTH_ACCESS_KEYS`).
pub const TOOTH_ACCESS: Script<'static> = Script {
    keys: &TOOTH_ACCESS_KEYS,
};

/// The real-size premolar's access cavity (`PREMOLAR_ACCESS_KEYS`).
pub const PREMOLAR_ACCESS: Script<'static> = Script {
    keys: &PREMOLAR_ACCESS_KEYS,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_and_holds_the_ends() {
        assert_eq!(DEMO.at(0).0, Vec3::new(0.0, 0.0, 0.9));
        assert_eq!(DEMO.at(100_000).0, Vec3::new(-0.2, -0.2, 0.9));
        let (p, b) = DEMO.at(200);
        assert!((p.z - 0.76).abs() < 1e-6);
        assert_eq!(b, 0);
        assert_eq!(DEMO.at(1000).1, DRILL_ON);
        assert_eq!(DEMO.ticks(), 6001);
        assert_eq!(Script { keys: &[] }.at(5), (Vec3::ZERO, 0));
    }

    #[test]
    fn the_tooth_path_plunges_with_the_drill_on_and_ends_withdrawn() {
        assert_eq!(TOOTH_ACCESS.ticks(), 17_601);
        assert_eq!(TOOTH_ACCESS.at(0), (Vec3::new(0.0, 0.0, 0.0235), 0));
        let (p, b) = TOOTH_ACCESS.at(10_000);
        assert!(p.abs_diff_eq(Vec3::new(0.0, 0.0, 0.0196), 1e-7), "{p}");
        assert_eq!(b, DRILL_ON);
        assert_eq!(TOOTH_ACCESS.at(20_000), (Vec3::new(0.0, 0.0, 0.0235), 0));
        assert!(TOOTH_ACCESS_KEYS.windows(2).all(|w| w[0].tick < w[1].tick));
    }

    #[test]
    fn the_premolar_path_opens_the_pulp_with_the_drill_on_and_ends_withdrawn() {
        assert_eq!(PREMOLAR_ACCESS.ticks(), 27_001);
        assert_eq!(PREMOLAR_ACCESS.at(0), (Vec3::new(0.0, 0.0, 0.024), 0));
        // Halfway along the buccal sweep, and at the deepest point.
        let (p, b) = PREMOLAR_ACCESS.at(7_500);
        assert!(p.abs_diff_eq(Vec3::new(0.0, 0.0006, 0.0196), 1e-7), "{p}");
        assert_eq!(b, DRILL_ON);
        let (p, b) = PREMOLAR_ACCESS.at(19_300);
        assert!(p.abs_diff_eq(Vec3::new(0.0, 0.0, 0.0179), 1e-7), "{p}");
        assert_eq!(b, DRILL_ON);
        // Withdrawn, then the drill off.
        assert_eq!(PREMOLAR_ACCESS.at(26_000).1, DRILL_ON);
        assert_eq!(PREMOLAR_ACCESS.at(26_800).1, 0);
        assert_eq!(PREMOLAR_ACCESS.at(30_000), (Vec3::new(0.0, 0.0, 0.024), 0));
        assert!(PREMOLAR_ACCESS_KEYS
            .windows(2)
            .all(|w| w[0].tick < w[1].tick));
    }
}
