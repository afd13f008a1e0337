//! Materials per region: how hard each part of the object is to drill, how hard the burr must
//! press before it cuts at all, and how stiff it feels (docs/DRILLING.md, "Materials").
//!
//! The erosion model follows the energy-based erosion of Agus et al. (2003): the burr removes
//! material at a rate proportional to the work it does on it, and removing a unit volume of a
//! given material takes a fixed amount of work. With the burr spinning at a constant speed the
//! work per second grows with the force pressing it against the material, so the volume a
//! region loses per second is
//!
//! ```text
//! dV/dt = (F - F_threshold) / H      while F > F_threshold, else 0
//! ```
//!
//! with `F` the servo's contact force (newtons), `F_threshold` the region's pressure threshold
//! (newtons) and `H` its hardness (newton-seconds per cubic mesh unit: the specific cutting
//! energy divided by the burr's cutting speed and friction). Leaves are still erased whole:
//! each region accumulates the volume its erosion has earned ([`Region::credit`], caller
//! storage, one entry per region), and a leaf is erased once its region's credit covers the
//! leaf's volume, which is then spent. A hardness of zero removes at once (no rate limit):
//! with a threshold of zero too, that is the drill as it is without materials.
//!
//! A region may instead be cut by the feed ([`Region::with_cutting_energy`]): removing a
//! volume `V` of it takes `e V` of work (`e` its specific cutting energy, newtons per square
//! mesh unit, joules per cubic metre for a mesh in metres), and that work is the one the
//! hand does pushing the burr into the material against the contact's reaction,
//! `F * max(0, -dc . n)` over each step (`F` the servo's force, `dc` the burr's motion, `n`
//! the contact's outward normal). The work goes to one pool shared by the regions cut this
//! way, and a leaf of such a region is erased once the pool covers `e` times its volume: the
//! energy the removed material took equals the work done against the feed
//! ([`Regions::cutting_work`], [`Regions::cutting_energy`]; docs/DRILLING.md, "Cutting
//! resistance"). The reaction the hand feels is the contact's spring: the material yields
//! only as fast as the work pays for it, so pushing at a steady speed into a region settles at
//! the force `e A` for a cut cross-section `A`, whatever the speed.

use crate::ids::TetId;

/// What a region is made of. [`Material::DEFAULT`] (hardness 0, threshold 0, the force
/// parameters' stiffness) removes material whatever the force, at once: the drill without
/// materials.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct Material {
    /// Newton-seconds per cubic mesh unit: the pressing force above the threshold, held for a
    /// second, removes `1 / hardness` cubic mesh units per newton. Zero: removed at once, as
    /// soon as the force reaches the threshold.
    pub hardness: f32,
    /// Newtons: the burr must press harder than this (at least this with a hardness of zero)
    /// for the material to be removed at all.
    pub threshold: f32,
    /// Contact stiffness, newtons per mesh unit of depth; zero: the force parameters' own
    /// ([`crate::force::ForceParams::stiffness`]).
    pub stiffness: f32,
}

impl Material {
    /// Hardness 0, threshold 0, the force parameters' stiffness: removed at once, whatever the
    /// force.
    pub const DEFAULT: Self = Self {
        hardness: 0.0,
        threshold: 0.0,
        stiffness: 0.0,
    };

    /// `true` when a pressing force of `force` newtons removes this material: above the
    /// threshold, or at least the threshold when the hardness is zero. A force that is not a
    /// number counts as zero.
    #[inline]
    pub(crate) fn admits(&self, force: f32) -> bool {
        let f = if force.is_nan() { 0.0 } else { force };
        if self.rate_limited() {
            f > self.threshold
        } else {
            f >= self.threshold
        }
    }

    /// `true` when removal is limited by a rate (a positive, finite hardness).
    #[inline]
    pub fn rate_limited(&self) -> bool {
        self.hardness > 0.0 && self.hardness.is_finite()
    }

    /// The volume removed per second, cubic mesh units, while pressed with `force` newtons:
    /// `(force - threshold) / hardness` above the threshold, zero below; infinite for a
    /// material removed at once that the force admits.
    pub(crate) fn rate(&self, force: f32) -> f64 {
        if !self.admits(force) {
            0.0
        } else if self.rate_limited() {
            (f64::from(force) - f64::from(self.threshold)) / f64::from(self.hardness)
        } else {
            f64::INFINITY
        }
    }
}

impl Default for Material {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One region's material and state, in caller storage (40 bytes): the volume its erosion has
/// earned and not yet spent, the volume removed from it, the amplitude of the burr's
/// vibration in it ([`Region::with_vibration`]), its specific cutting energy
/// ([`Region::with_cutting_energy`]) and its friction with the spinning burr
/// ([`Region::with_friction`]).
#[derive(Clone, Copy, PartialEq, Debug, Default)]
pub struct Region {
    /// The region's material.
    pub material: Material,
    /// Newtons: the burr's vibration at full cut (docs/DRILLING.md, "Vibration"); zero: none.
    vibration: f32,
    /// Newtons per square mesh unit: the work the feed does per unit volume removed; zero:
    /// the material's hardness law instead.
    cutting_energy: f32,
    /// The friction coefficient between the spinning burr and this material (zero: none).
    friction: f32,
    credit: f64,
    removed: f64,
}

const _: () = assert!(core::mem::size_of::<Region>() == 40);

impl Region {
    /// A region of `material`, nothing earned or removed yet.
    pub const fn new(material: Material) -> Self {
        Self {
            material,
            vibration: 0.0,
            cutting_energy: 0.0,
            friction: 0.0,
            credit: 0.0,
            removed: 0.0,
        }
    }

    /// This region with a friction coefficient of `mu` between the spinning burr and its
    /// material: while the drill is on and the burr presses it, the servo adds a sideways
    /// pull of `mu` times the spring's force along `spin x n` ([`crate::servo::servo_force`],
    /// "Sideways pull"). Zero, negative or not a number: none (the default).
    pub const fn with_friction(self, mu: f32) -> Self {
        let friction = if mu > 0.0 && mu < f32::INFINITY {
            mu
        } else {
            0.0
        };
        Self { friction, ..self }
    }

    /// The friction coefficient between the spinning burr and this region (zero: none).
    pub fn friction(&self) -> f32 {
        self.friction
    }

    /// This region's settings (material, vibration, cutting energy) with nothing earned or
    /// removed: the region as a new world starts it.
    pub const fn fresh(&self) -> Self {
        Self {
            credit: 0.0,
            removed: 0.0,
            ..*self
        }
    }

    /// This region cut by the feed, with a specific cutting energy of `e` newtons per square
    /// mesh unit (joules per cubic metre for a mesh in metres): a leaf of it is erased once
    /// the work done pushing the burr into the material pays `e` times its volume (module
    /// docs). Its hardness is not used then; its threshold and stiffness are. Zero, negative
    /// or not a number: the hardness law (the default).
    pub const fn with_cutting_energy(self, e: f32) -> Self {
        let cutting_energy = if e > 0.0 && e < f32::INFINITY { e } else { 0.0 };
        Self {
            cutting_energy,
            ..self
        }
    }

    /// Newtons per square mesh unit: the work the feed does per unit volume of this region
    /// removed (zero: the hardness law).
    pub fn cutting_energy(&self) -> f32 {
        self.cutting_energy
    }

    /// `true` when this region is cut by the feed (a positive cutting energy).
    #[inline]
    pub fn feed_limited(&self) -> bool {
        self.cutting_energy > 0.0
    }

    /// This region with a vibration of `newtons` at full cut: while the drill is on and the
    /// burr cuts this region, [`crate::servo::servo_force`] adds a sinusoid of at most this
    /// amplitude along the force ([`crate::servo::VibrationCue`]). Zero, negative or not a
    /// number: none (the default).
    pub const fn with_vibration(self, newtons: f32) -> Self {
        let vibration = if newtons > 0.0 && newtons < f32::INFINITY {
            newtons
        } else {
            0.0
        };
        Self { vibration, ..self }
    }

    /// Newtons: the amplitude of the burr's vibration at full cut in this region (zero:
    /// none).
    pub fn vibration(&self) -> f32 {
        self.vibration
    }

    /// Volume the burr's work has earned in this region and not yet spent on a leaf, cubic
    /// mesh units.
    pub fn credit(&self) -> f64 {
        self.credit
    }

    /// Volume removed from this region so far, cubic mesh units (the sum of the volumes of
    /// its erased leaves).
    pub fn removed(&self) -> f64 {
        self.removed
    }
}

/// How many steps' worth of credit a region keeps while no leaf of it is waiting: the drill
/// queues a held burr's position again every [`super::DRILL_HOLD_STEPS`] steps, so credit
/// earned between two queued positions is not lost; work the burr does on nothing dissipates
/// beyond that.
pub(crate) const CREDIT_STEPS: f64 = 2.0 * super::DRILL_HOLD_STEPS as f64;

/// Why [`Regions::new`] refused its storage.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[non_exhaustive]
pub enum RegionError {
    /// No region at all (region 0 is every tet's that names none).
    Empty,
    /// More regions than a tet's `u8` index reaches.
    TooMany {
        /// Regions given.
        regions: usize,
    },
    /// A tet names a region beyond the table.
    Unknown {
        /// The tet.
        tet: u32,
        /// Its region.
        region: u8,
        /// Regions in the table.
        regions: usize,
    },
}

impl core::fmt::Display for RegionError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Empty => write!(f, "the region table is empty"),
            Self::TooMany { regions } => {
                write!(f, "{regions} regions (at most 256: a tet's region is a u8)")
            }
            Self::Unknown {
                tet,
                region,
                regions,
            } => write!(
                f,
                "tet {tet} names region {region}, but the table has {regions} regions"
            ),
        }
    }
}

impl core::error::Error for RegionError {}

/// The regions of an object, over caller storage: each region's [`Region`] and each coarse
/// tet's region index (a leaf takes the region of its root tet). A tet beyond `of_tet` is in
/// region 0.
#[derive(Debug)]
pub struct Regions<'a> {
    table: &'a mut [Region],
    of_tet: &'a [u8],
    /// The pressing force the last grant used, newtons.
    force: f32,
    /// Whether the burr was cutting at the last grant.
    cutting: bool,
    /// The region of the leaf waiting for credit, and the volume it needs.
    waiting: Option<(u8, f64)>,
    /// Whether some region is cut by the feed (fixed when the regions are made).
    feed: bool,
    /// Work done against the feed and not yet spent on a leaf, newton mesh units.
    pool: f64,
    /// Work done against the feed on material cut by it, newton mesh units, in all.
    work: f64,
    /// Work spent on the leaves of regions cut by the feed, newton mesh units, in all.
    energy: f64,
    /// Work the pool could not keep, newton mesh units, in all.
    dropped: f64,
}

/// What [`Regions::spend`] decided for a leaf.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Spend {
    /// The leaf's volume was taken from its region's credit (or its material is removed at
    /// once): erase it.
    Erase,
    /// Its region's credit does not cover it yet: the leaf waits for more work.
    Wait,
    /// A leaf of a region cut by the feed, reached while the burr presses nothing (admitted
    /// by the pool's work, [`Regions::admits_paid`], or by a threshold of zero), that the
    /// pool does not cover: it is left, not waited for (nothing pays into the pool until the
    /// burr presses again), so the queue drains and the rest of the pool is dropped.
    Drop,
}

impl<'a> Regions<'a> {
    /// Regions `table` (at most 256) with each coarse tet's region index in `of_tet`.
    ///
    /// # Bounded work
    /// O(`of_tet` length), once.
    ///
    /// # Errors
    /// [`RegionError`]: an empty or too long table, a tet naming a region beyond it.
    pub fn new(table: &'a mut [Region], of_tet: &'a [u8]) -> Result<Self, RegionError> {
        if table.is_empty() {
            return Err(RegionError::Empty);
        }
        if table.len() > 256 {
            return Err(RegionError::TooMany {
                regions: table.len(),
            });
        }
        if let Some((t, &r)) = of_tet
            .iter()
            .enumerate()
            .find(|(_, &r)| r as usize >= table.len())
        {
            return Err(RegionError::Unknown {
                tet: t as u32,
                region: r,
                regions: table.len(),
            });
        }
        let feed = table.iter().any(Region::feed_limited);
        Ok(Self {
            table,
            of_tet,
            force: 0.0,
            cutting: false,
            waiting: None,
            feed,
            pool: 0.0,
            work: 0.0,
            energy: 0.0,
            dropped: 0.0,
        })
    }

    /// The regions' state.
    pub fn table(&self) -> &[Region] {
        self.table
    }

    /// The region index of coarse tet `tet` (0 beyond the index slice): its entry in
    /// [`Regions::table`] (a surface's labels come from it).
    #[inline]
    pub fn region_of(&self, tet: TetId) -> u8 {
        self.of_tet.get(tet.idx()).copied().unwrap_or(0)
    }

    /// The region entry of coarse tet `tet` (`None` beyond the table).
    #[inline]
    pub(crate) fn region_entry(&self, tet: TetId) -> Option<&Region> {
        self.table.get(self.region_of(tet) as usize)
    }

    /// The material of coarse tet `tet`.
    #[inline]
    pub(crate) fn material_of(&self, tet: TetId) -> Material {
        self.table
            .get(self.region_of(tet) as usize)
            .map_or(Material::DEFAULT, |r| r.material)
    }

    /// Earns each region its credit for `dt` seconds of the burr pressing with `force`
    /// newtons: `rate(force) * dt` where the region's material admits the force and the burr
    /// is `cutting`; zero otherwise (work the burr does not do removes nothing later). A
    /// region's credit is kept to [`CREDIT_STEPS`] grants, or to what its waiting leaf needs
    /// when more. Returns the rate-limited regions visited (the work to charge).
    ///
    /// The regions cut by the feed earn instead the work `force * feed` (`feed` the burr's
    /// advance into the material since the last step, mesh units) when the burr is
    /// `cutting` and the material `under` the contact is cut by the feed and admits the
    /// force: added to [`Regions::cutting_work`] and to the pool their leaves are paid from.
    /// The pool keeps it while the burr cuts (the work was done on material the drill has
    /// still to remove: the queue's, or the next position's) and, once the burr stops
    /// cutting, while the drill has work `queued`; then it empties
    /// ([`Regions::feed_dropped`]).
    ///
    /// # Bounded work
    /// O(regions).
    pub(crate) fn grant(
        &mut self,
        force: f32,
        dt: f32,
        cutting: bool,
        feed: f32,
        under: Option<TetId>,
        queued: bool,
    ) -> u32 {
        self.grant_feed(force, cutting, feed, under, queued) + self.grant_rate(force, dt, cutting)
    }

    /// The feed's part of [`Regions::grant`]: 1 when some region is cut by the feed (the
    /// pool visited), else 0.
    fn grant_feed(
        &mut self,
        force: f32,
        cutting: bool,
        feed: f32,
        under: Option<TetId>,
        queued: bool,
    ) -> u32 {
        if !self.feed {
            return 0;
        }
        if !cutting {
            if !queued {
                self.dropped += self.pool;
                self.pool = 0.0;
            }
            return 1;
        }
        let paying = under
            .and_then(|t| self.region_entry(t))
            .is_some_and(|r| r.feed_limited() && r.material.admits(force));
        let w = f64::from(force) * f64::from(feed);
        let w = if paying && w > 0.0 && w.is_finite() {
            w
        } else {
            0.0
        };
        self.work += w;
        self.pool += w;
        1
    }

    /// The hardness law's part of [`Regions::grant`]: the rate-limited regions visited.
    fn grant_rate(&mut self, force: f32, dt: f32, cutting: bool) -> u32 {
        let force = if force.is_finite() {
            force.max(0.0)
        } else {
            0.0
        };
        let dt = if dt.is_finite() {
            f64::from(dt.max(0.0))
        } else {
            0.0
        };
        self.force = force;
        self.cutting = cutting;
        let mut visited = 0;
        for (i, r) in self.table.iter_mut().enumerate() {
            if !r.material.rate_limited() || r.feed_limited() {
                continue;
            }
            visited += 1;
            let g = if cutting {
                r.material.rate(force) * dt
            } else {
                0.0
            };
            if g <= 0.0 {
                r.credit = 0.0;
                continue;
            }
            let need = match self.waiting {
                Some((w, v)) if w as usize == i => v,
                _ => 0.0,
            };
            r.credit = (r.credit + g).min((g * CREDIT_STEPS).max(need));
        }
        visited
    }

    /// `true` when the last grant's force removes the material of `tet` (its leaves are worth
    /// refining and erasing).
    #[inline]
    pub(crate) fn admits(&self, tet: TetId) -> bool {
        self.material_of(tet).admits(self.force)
    }

    /// `true` when the burr presses nothing (the last grant's force is zero) and `tet`'s
    /// region is cut by the feed and the pool holds the work of a `leaf` of it (its volume,
    /// asked for only then): the material the burr pressed on its way and the drill has still
    /// to reach (its queue) is cut with the work done on it once the burr has left (the force
    /// gates the cut only while the burr presses). A leaf the pool then no longer covers is
    /// dropped ([`Spend::Drop`]).
    ///
    /// # Bounded work
    /// Constant, and `leaf` called at most once.
    #[inline]
    pub(crate) fn admits_paid(&self, tet: TetId, leaf: impl FnOnce() -> f64) -> bool {
        if !self.presses_nothing() || self.pool <= 0.0 {
            return false;
        }
        self.region_entry(tet)
            .is_some_and(|r| r.feed_limited() && self.pool >= f64::from(r.cutting_energy) * leaf())
    }

    /// `true` when the last grant's force is zero: the burr presses nothing, so no work is
    /// paid into the pool until it presses again and a leaf of the feed's regions the pool
    /// does not cover is left, not waited for.
    #[inline]
    fn presses_nothing(&self) -> bool {
        self.force <= 0.0
    }

    /// `true` when a leaf of `tet` must be paid for ([`Regions::spend`]): its region is
    /// rate-limited or cut by the feed.
    #[inline]
    pub(crate) fn limits(&self, tet: TetId) -> bool {
        self.region_entry(tet)
            .is_some_and(|r| r.feed_limited() || r.material.rate_limited())
    }

    /// Decides whether a leaf of `tet` of `volume` is erased now: always for a material
    /// removed at once; for a rate-limited one when its region's credit covers `volume`
    /// (taken from the credit), for one cut by the feed when the pool covers its cutting
    /// energy times `volume` (taken from the pool, counted in [`Regions::cutting_energy`]),
    /// else, while the burr presses nothing, it is left ([`Spend::Drop`]); otherwise it waits
    /// (remembered, so the next grants may exceed [`CREDIT_STEPS`] up to what it needs).
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn spend(&mut self, tet: TetId, volume: f64) -> Spend {
        let r = self.region_of(tet);
        let Some(reg) = self.table.get_mut(r as usize) else {
            return Spend::Erase;
        };
        if reg.feed_limited() {
            let need = f64::from(reg.cutting_energy) * volume;
            return if self.pool >= need {
                self.pool -= need;
                self.energy += need;
                if self.waiting.is_some_and(|(w, _)| w == r) {
                    self.waiting = None;
                }
                Spend::Erase
            } else if self.presses_nothing() {
                Spend::Drop
            } else {
                self.waiting = Some((r, volume));
                Spend::Wait
            };
        }
        if !reg.material.rate_limited() {
            return Spend::Erase;
        }
        if reg.credit >= volume {
            reg.credit -= volume;
            if self.waiting.is_some_and(|(w, _)| w == r) {
                self.waiting = None;
            }
            Spend::Erase
        } else {
            self.waiting = Some((r, volume));
            Spend::Wait
        }
    }

    /// Work done against the feed on material cut by it, newton mesh units (joules for a
    /// mesh in metres), since the regions were made (module docs).
    pub fn cutting_work(&self) -> f64 {
        self.work
    }

    /// The cutting energy of the leaves cut by the feed, newton mesh units: each erased
    /// leaf's volume times its region's [`Region::cutting_energy`], summed. Equal to
    /// [`Regions::cutting_work`] but for the work still in the pool and the work the pool
    /// could not keep; debris erased whole is not cut and costs none.
    pub fn cutting_energy(&self) -> f64 {
        self.energy
    }

    /// Work done against the feed and not yet spent on a leaf, newton mesh units.
    pub fn feed_pool(&self) -> f64 {
        self.pool
    }

    /// Work done against the feed and left in the pool when the burr stopped cutting and the
    /// drill had nothing left to remove, newton mesh units, in all:
    /// [`Regions::cutting_work`] is the cutting energy, the pool and this.
    pub fn feed_dropped(&self) -> f64 {
        self.dropped
    }

    /// Adds `volume` to the removed volume of `tet`'s region.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn note_removed(&mut self, tet: TetId, volume: f64) {
        let r = self.region_of(tet) as usize;
        if let Some(reg) = self.table.get_mut(r) {
            reg.removed += volume;
        }
    }
}

impl<'a> super::Drill<'a> {
    /// Sets the materials per region: from now on an item of a material the pressing force
    /// does not remove is dropped, and a leaf of a rate-limited material is erased only once
    /// its region has earned its volume ([`Regions::spend`]). Without regions (the default)
    /// every leaf is removed at once, whatever the force.
    ///
    /// # Bounded work
    /// O(1).
    pub(crate) fn set_regions(&mut self, regions: Regions<'a>) {
        self.regions = Some(regions);
    }

    /// The materials per region, if set.
    pub(crate) fn regions(&self) -> Option<&Regions<'a>> {
        self.regions.as_ref()
    }

    /// The materials per region, if set, to grant them credit.
    pub(crate) fn regions_mut(&mut self) -> Option<&mut Regions<'a>> {
        self.regions.as_mut()
    }

    /// `true` when the pressing force removes the material of `tet` (always without regions).
    #[inline]
    pub(super) fn admits(&self, tet: TetId) -> bool {
        self.regions.as_ref().is_none_or(|r| r.admits(tet))
    }

    /// `true` when the burr presses nothing and the feed's pool holds the work of a leaf of
    /// `tet` at `depth` ([`Regions::admits_paid`]); never without regions.
    #[inline]
    pub(super) fn admits_paid(&self, mesh: &crate::mesh::Mesh<'_>, tet: TetId, depth: u8) -> bool {
        self.regions
            .as_ref()
            .is_some_and(|r| r.admits_paid(tet, || crate::hierarchy::node_volume(mesh, tet, depth)))
    }

    /// Whether a leaf of `tet` at `depth` is erased now ([`Regions::spend`] of its volume,
    /// `root volume / 8^depth`); always without regions.
    #[inline]
    pub(super) fn spend(&mut self, mesh: &crate::mesh::Mesh<'_>, tet: TetId, depth: u8) -> Spend {
        match self.regions.as_mut() {
            Some(r) if r.limits(tet) => {
                r.spend(tet, crate::hierarchy::node_volume(mesh, tet, depth))
            }
            _ => Spend::Erase,
        }
    }

    /// Counts `volume` erased from `tet` in its region.
    #[inline]
    pub(super) fn note_removed(&mut self, tet: TetId, volume: f64) {
        if let Some(r) = self.regions.as_mut() {
            r.note_removed(tet, volume);
        }
    }
}
