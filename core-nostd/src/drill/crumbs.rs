//! The drill's debris checks: every leaf the drill erases is a seed ([`Crumbs`]); the checks
//! run within the step's budget, charged like the drill's own NTree visits.

use super::cost::WorkCost;
use super::step::{Drill, DrillReport};
use crate::hierarchy::{CrumbStats, Hierarchy};
use crate::mesh::Mesh;

impl Drill<'_> {
    /// Sets the debris size the drill's checks erase below, in max-depth leaves
    /// ([`crate::hierarchy::DEBRIS_LEAVES`] by default; 0 turns the checks off).
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn set_debris_leaves(&mut self, max_leaves: u32) {
        self.crumbs.set_max_leaves(max_leaves);
    }

    /// What the drill's debris checks erased and how often they saturated, since creation.
    pub(crate) fn debris(&self) -> CrumbStats {
        self.crumbs.stats()
    }

    /// Erased leaves whose debris check waits for budget.
    pub(crate) fn debris_pending(&self) -> usize {
        self.crumbs.pending()
    }

    /// Checks one seed ([`crate::hierarchy::Crumbs::check_one`]), charging
    /// [`WorkCost::TAKEN`] plus [`WorkCost::VISIT`] per NTree node touched; the debris erased
    /// is counted in the regions' removed volume. `false` when no seed waits.
    pub(super) fn check_crumb(
        &mut self,
        h: &mut Hierarchy<'_>,
        mesh: &Mesh<'_>,
        max_depth: u8,
        rep: &mut DrillReport,
    ) -> bool {
        let regions = &mut self.regions;
        let done = self.crumbs.check_one(h, mesh, max_depth, |tet, v| {
            if let Some(r) = regions.as_mut() {
                r.note_removed(tet, v);
            }
        });
        let Some(w) = done else {
            return false;
        };
        rep.work = rep
            .work
            .saturating_add(WorkCost::TAKEN + WorkCost::VISIT * w.visits);
        rep.visits = rep.visits.saturating_add(w.visits);
        rep.debris_checked += 1;
        rep.debris_erased += w.erased;
        true
    }

    /// Checks seeds while the step's budget lasts (one batch: nothing else changes the
    /// hierarchy meanwhile).
    pub(super) fn check_crumbs(
        &mut self,
        h: &mut Hierarchy<'_>,
        mesh: &Mesh<'_>,
        max_depth: u8,
        budget: u32,
        rep: &mut DrillReport,
    ) {
        self.crumbs.forget();
        while rep.work < budget && self.check_crumb(h, mesh, max_depth, rep) {}
    }
}
