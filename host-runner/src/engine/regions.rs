//! The regions of a world: one material per distinct label of the mesh ([`region_table`]),
//! and the volume removed from each ([`removed_by_region`]).

use std::collections::BTreeMap;

use tetradrill_core::drill::Material;
use tetradrill_core::servo::World;

use crate::error::Error;
use crate::setup::Materials;

/// The regions of a world: one per distinct label of the mesh, in label order.
#[derive(Debug, Clone, PartialEq)]
pub struct RegionTable {
    /// The label of each region.
    pub labels: Vec<i32>,
    /// The material of each region: the set-up's entry for its label, else the default
    /// region's (`hardness`, `pressure_threshold`, the set-up's stiffness).
    pub materials: Vec<Material>,
    /// The display colour of each region, where the set-up gives one.
    pub colours: Vec<Option<[f32; 3]>>,
    /// The burr's vibration at full cut in each region, newtons (0: none; the set-up's
    /// `vibration` of its label).
    pub vibrations: Vec<f32>,
    /// The specific cutting energy of each region, joules per cubic mesh unit (0: the
    /// hardness law; the set-up's `cutting_energy` of its label).
    pub cutting_energies: Vec<f32>,
    /// The friction coefficient of each region with the spinning burr (0: none; the set-up's
    /// `friction` of its label).
    pub frictions: Vec<f32>,
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
    let materials = distinct
        .iter()
        .map(|l| by_label.get(l).map_or(default, |r| r.material()))
        .collect();
    let colours = distinct
        .iter()
        .map(|l| by_label.get(l).and_then(|r| r.rgb()))
        .collect();
    let vibrations = distinct
        .iter()
        .map(|l| by_label.get(l).and_then(|r| r.vibration).unwrap_or(0.0) as f32)
        .collect();
    let cutting_energies = distinct
        .iter()
        .map(|l| {
            by_label
                .get(l)
                .and_then(|r| r.cutting_energy)
                .unwrap_or(0.0) as f32
        })
        .collect();
    let frictions = distinct
        .iter()
        .map(|l| by_label.get(l).and_then(|r| r.friction).unwrap_or(0.0) as f32)
        .collect();
    let of_tet = labels
        .iter()
        .map(|l| distinct.binary_search(l).unwrap_or(0) as u8)
        .collect();
    Ok(Some(RegionTable {
        labels: distinct,
        materials,
        colours,
        vibrations,
        cutting_energies,
        frictions,
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
