//! The real-size premolar's built-in scenario, `builtin:tooth` (docs/DRILLING.md, "The
//! real-size premolar"); `builtin:firmware-tooth` keeps the small tooth the firmware's memory
//! is sized for.

use super::builtins::test_mesh;
use super::{labelled, Scenario};
use crate::setup::tooth_regions;

/// The real-size premolar of `builtin:tooth`, in the project's test data folder.
pub const PREMOLAR: &str = "models/premolar_gmsh.msh22.msh";

/// `builtin:tooth`: the real-size premolar on the host (`models/premolar_gmsh.msh22.msh`,
/// 44,162 tets). A 0.7 mm burr (an ISO 014 round burr) cuts an access cavity through the
/// enamel and the dentin into the pulp chamber (`script::PREMOLAR_ACCESS`), with the tooth's
/// three materials (`tooth_regions`); metres and newtons, the host's budgets. The capacities
/// hold the peaks `replay --json` reports on the whole path.
pub(super) fn real_size_tooth() -> Scenario {
    Scenario {
        mesh: test_mesh(PREMOLAR),
        trace: "builtin:premolar-access".into(),
        tool: "sphere:0.0007".into(),
        stiffness: 6_000.0,
        regions: labelled(tooth_regions()),
        // Peaks over the path at larger sizes: 3,118,480 arena nodes, 13,819 coarse pending
        // items, 3,241 candidates; each capacity a quarter or more above. The tet hash is
        // filled once at load (339,354 entries of its default 8 a tet).
        hierarchy_capacity: Some(4_100_000),
        pending_capacity: Some(40_960),
        candidate_capacity: Some(4_096),
        // Every tet to `max_depth` (5), as its figures in docs/DRILLING.md were measured: the
        // derived default (an 8th of the burr's radius) stops these small tets a level or
        // two higher.
        resolution: Some(0.0),
        ..Scenario::default()
    }
}
