//! The regions of a world: one material per distinct label of the mesh ([`region_table`]),
//! and the volume removed from each ([`removed_by_region`]).

use std::collections::BTreeMap;

use tetradrill_core::drill::{Material, Region};
use tetradrill_core::servo::World;

use crate::error::Error;
use crate::setup::{Materials, RegionSpec};

/// The regions of a world: one per distinct label of the mesh, in label order.
#[derive(Debug, Clone, PartialEq)]
pub struct RegionTable {
    /// The label of each region.
    pub labels: Vec<i32>,
    /// Each region as the core takes it: the set-up's entry for its label (material,
    /// `vibration`, `cutting_energy`, `friction`), else the default region's material
    /// (`hardness`, `pressure_threshold`, the set-up's stiffness) and nothing else.
    pub regions: Vec<Region>,
    /// The display colour of each region, where the set-up gives one.
    pub colours: Vec<Option<[f32; 3]>>,
    /// Each tet's region index.
    pub of_tet: Vec<u8>,
}

/// The regions of `labels` (one per tet) under `materials`. `Ok(None)` when the mesh has more
/// than 256 distinct labels and no material is set (a world then runs without regions, as
/// every material would be the default one).
///
/// # Errors
/// [`Error::TooManyRegions`]: more than 256 distinct labels with materials set.
pub fn region_table(labels: &[i32], materials: &Materials) -> Result<Option<RegionTable>, Error> {
    let mut distinct: Vec<i32> = labels.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.is_empty() {
        distinct.push(0);
    }
    let default = Material {
        hardness: materials.hardness as f32,
        threshold: materials.pressure_threshold as f32,
        stiffness: 0.0,
    };
    if distinct.len() > 256 {
        if materials.regions.is_empty() && default == Material::DEFAULT {
            return Ok(None);
        }
        return Err(Error::TooManyRegions {
            labels: distinct.len(),
        });
    }
    let by_label = &materials.regions;
    let regions = distinct
        .iter()
        .map(|l| {
            by_label
                .get(l)
                .map_or(Region::new(default), RegionSpec::region)
        })
        .collect();
    let colours = distinct
        .iter()
        .map(|l| by_label.get(l).and_then(|r| r.rgb()))
        .collect();
    let of_tet = labels
        .iter()
        .map(|l| distinct.binary_search(l).unwrap_or(0) as u8)
        .collect();
    Ok(Some(RegionTable {
        labels: distinct,
        regions,
        colours,
        of_tet,
    }))
}

/// The volume removed from each region of `world`, by label (`None` without regions).
pub fn removed_by_region(world: &World<'_>, labels: &[i32]) -> Option<BTreeMap<String, f64>> {
    let r = world.regions()?;
    Some(
        r.table()
            .iter()
            .zip(labels)
            .map(|(reg, l)| (l.to_string(), reg.removed()))
            .collect(),
    )
}
