//! The soft step with its tet sweeps split in two parts that share no node, for a caller that
//! runs them on two threads ([`SoftBody::step_two`]). The core stays single-threaded: it hands
//! the two parts to the caller's `fork`, which may run them at the same time (each holds
//! only its own nodes' storage), then sweeps the tets that join them itself.
//!
//! A body whose tets are ordered as [`TwoParts`] describes (tets `0..tets_a` naming only nodes
//! `0..nodes_a`, tets `tets_a..tets_b` only nodes `nodes_a..`, the rest any node) steps here
//! with the bits [`SoftBody::step`] gives it: its sweep runs the tets in the same order, and
//! the first two parts change disjoint nodes, so running them together changes nothing.

use glam::Vec3;

use super::resume::{integrate, sweep, velocity, TetRun};
use super::{SoftBody, StepError};

/// A checked split of a body's nodes and tets into two parts that share no node and the tets
/// that join them ([`SoftBody::two_parts`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TwoParts {
    nodes_a: usize,
    tets_a: usize,
    tets_b: usize,
}

impl TwoParts {
    /// Nodes of the first part (`0..nodes_a`; the second part has the rest).
    pub fn nodes_a(&self) -> usize {
        self.nodes_a
    }

    /// Tets of the first part (`0..tets_a`).
    pub fn tets_a(&self) -> usize {
        self.tets_a
    }

    /// End of the second part's tets (`tets_a..tets_b`); the joining tets are `tets_b..`.
    pub fn tets_b(&self) -> usize {
        self.tets_b
    }
}

/// One part's sweep over its tets for [`SoftBody::step_two`]'s `fork`: [`PartSweep::run`]
/// solves them (once; a second call does nothing).
#[derive(Debug)]
pub struct PartSweep<'s> {
    work: Option<(TetRun<'s>, &'s mut [Vec3], &'s [f32], usize)>,
    first: bool,
    inv_h2: f32,
}

impl core::fmt::Debug for TetRun<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("TetRun")
            .field("tets", &self.tets.len())
            .finish_non_exhaustive()
    }
}

impl PartSweep<'_> {
    /// Solves the part's tets in order, unless done already.
    ///
    /// # Bounded work
    /// O(the part's tets), the first call; constant after.
    pub fn run(&mut self) {
        if let Some((tets, displacement, inv_mass, first_node)) = self.work.take() {
            sweep(
                tets,
                displacement,
                inv_mass,
                first_node,
                self.first,
                self.inv_h2,
            );
        }
    }

    /// Tets this sweep solves (zero once run).
    pub fn tet_count(&self) -> usize {
        self.work.as_ref().map_or(0, |w| w.0.tets.len())
    }
}

impl SoftBody<'_> {
    /// Checks that the body's tets and nodes are ordered as two parts that share no node:
    /// tets `0..tets_a` name only nodes `0..nodes_a`, tets `tets_a..tets_b` only nodes
    /// `nodes_a..`, the tets after `tets_b` any node. `None` when they are not (or the counts
    /// are out of order or past the end).
    ///
    /// # Bounded work
    /// O(T).
    pub fn two_parts(&self, nodes_a: usize, tets_a: usize, tets_b: usize) -> Option<TwoParts> {
        let n = self.rest.len();
        if !(nodes_a <= n && tets_a <= tets_b && tets_b <= self.tets.len()) {
            return None;
        }
        let (a, rest) = self.tets.split_at(tets_a);
        let b = rest.get(..tets_b - tets_a)?;
        let in_a = a.iter().flatten().all(|&k| (k as usize) < nodes_a);
        let in_b = b.iter().flatten().all(|&k| (k as usize) >= nodes_a);
        (in_a && in_b).then_some(TwoParts {
            nodes_a,
            tets_a,
            tets_b,
        })
    }

    /// One step of `dt` as [`SoftBody::step`] does it, with each sweep's tets of the two
    /// parts handed to `fork` (the first part's sweep, the second's), which runs both
    /// ([`PartSweep::run`]), on two threads if it likes: each holds only its part's nodes. A
    /// part `fork` left unrun is run after it returns. Then the joining tets are swept here.
    /// The result is the bits [`SoftBody::step`] gives (module docs). Refused, nothing
    /// changed, as [`SoftBody::step`] refuses.
    ///
    /// # Bounded work
    /// As [`SoftBody::step`], plus `substeps x iterations` calls of `fork`.
    pub fn step_two(
        &mut self,
        dt: f32,
        external: &[Vec3],
        parts: TwoParts,
        fork: &mut dyn FnMut(&mut PartSweep<'_>, &mut PartSweep<'_>),
    ) -> Result<(), StepError> {
        self.begin_step(dt)?;
        let Some(r) = self.run.take() else {
            return Ok(());
        };
        let n = self.rest.len();
        let TwoParts {
            nodes_a,
            tets_a,
            tets_b,
        } = parts;
        for _ in 0..r.substeps {
            integrate(&mut self.s, external, &r, 0..n);
            for iteration in 0..r.iterations {
                let first = iteration == 0;
                let s = &mut self.s;
                let (tets_ab, tets_j) = self.tets.split_at(tets_b.min(self.tets.len()));
                let (rests_ab, rests_j) = s.tet_rest.split_at(tets_ab.len());
                let (lambdas_ab, lambdas_j) = s.lambdas.split_at_mut(tets_ab.len());
                {
                    let at = tets_a.min(tets_ab.len());
                    let (t_a, t_b) = tets_ab.split_at(at);
                    let (r_a, r_b) = rests_ab.split_at(at);
                    let (l_a, l_b) = lambdas_ab.split_at_mut(at);
                    let split = nodes_a.min(s.displacement.len());
                    let (u_a, u_b) = s.displacement.split_at_mut(split);
                    let (w_a, w_b) = s.inv_mass.split_at(split.min(s.inv_mass.len()));
                    let mut a = PartSweep {
                        work: Some((
                            TetRun {
                                tets: t_a,
                                rests: r_a,
                                lambdas: l_a,
                            },
                            u_a,
                            w_a,
                            0,
                        )),
                        first,
                        inv_h2: r.inv_h2,
                    };
                    let mut b = PartSweep {
                        work: Some((
                            TetRun {
                                tets: t_b,
                                rests: r_b,
                                lambdas: l_b,
                            },
                            u_b,
                            w_b,
                            split,
                        )),
                        first,
                        inv_h2: r.inv_h2,
                    };
                    fork(&mut a, &mut b);
                    a.run();
                    b.run();
                }
                sweep(
                    TetRun {
                        tets: tets_j,
                        rests: rests_j,
                        lambdas: lambdas_j,
                    },
                    s.displacement,
                    s.inv_mass,
                    0,
                    first,
                    r.inv_h2,
                );
            }
            velocity(&mut self.s, &r, 0..n);
        }
        Ok(())
    }
}
