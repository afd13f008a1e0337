//! The soft step's one implementation, resumable: [`SoftBody::begin_step`] fixes the step's
//! length, [`SoftBody::advance`] does at most a given amount of its work a call and goes on
//! where the last call stopped. [`SoftBody::step`] is the same two with an unlimited amount, so
//! the state after the last call is bit for bit the state one [`SoftBody::step`] leaves,
//! however the work is sliced.
//!
//! Work is counted in units: one node's update (the integration at the start of a substep,
//! or the velocity at its end) is [`NODE_UNITS`], one tet's constraint solve
//! ([`super::project`]) is [`TET_UNITS`]. A step costs
//! `substeps x (2 N x NODE_UNITS + iterations x T x TET_UNITS)` units
//! ([`SoftBody::step_units`]). A call takes as many items of the pass it is in as its units
//! allow and runs them as one loop, so a call with units to spare runs each pass whole.

use core::ops::Range;

use glam::Vec3;

#[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
use super::lanes;
use super::{project, SoftBody, SoftStorage, StepError, TetRest};

/// Work units of one node's update (integration or velocity).
pub(crate) const NODE_UNITS: u32 = 1;
/// Work units of one tet's constraint solve: on a Cortex-M4 a solve takes about as many
/// instructions as this many node updates, about 660 (docs/SOFT.md, "A step spread over
/// ticks").
pub const TET_UNITS: u32 = 18;

/// Where a step is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Damping, integrating and predicting node `at`.
    Integrate,
    /// Solving tet `at` in sweep `iteration`.
    Solve,
    /// The velocity of node `at` from its displacement change.
    Velocity,
}

/// A step under way: its constants and where it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Run {
    // The two-part step (`parts.rs`) reads the constants too.
    h: f32,
    inv_h: f32,
    pub(super) inv_h2: f32,
    keep: f32,
    gravity: Vec3,
    pub(super) substeps: u32,
    pub(super) iterations: u32,
    substep: u32,
    iteration: u32,
    phase: Phase,
    at: usize,
}

/// What one [`SoftBody::advance`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Advance {
    /// Work units done in this call.
    pub units: u32,
    /// `true` when the step is complete (no step is under way any more).
    pub done: bool,
}

/// How many of the `items` left of a pass fit in `left` units at `per` units each.
#[inline]
fn fitting(items: usize, left: u32, per: u32) -> usize {
    items.min((left / per) as usize)
}

/// A run of nodes' integration (the start of a substep): each node's displacement kept in
/// `previous`; a free node's velocity damped first (so a body at rest under a load feels all
/// of it), then given gravity and its force (`external`, missing entries zero), and its
/// displacement predicted.
pub(super) fn integrate(s: &mut SoftStorage<'_>, external: &[Vec3], r: &Run, nodes: Range<usize>) {
    let forces = external
        .get(nodes.start..)
        .unwrap_or(&[])
        .iter()
        .copied()
        .chain(core::iter::repeat(Vec3::ZERO));
    let (Some(u), Some(p), Some(v), Some(w)) = (
        s.displacement.get_mut(nodes.clone()),
        s.previous.get_mut(nodes.clone()),
        s.velocity.get_mut(nodes.clone()),
        s.inv_mass.get(nodes),
    ) else {
        return;
    };
    for ((((u, p), v), &w), f) in u.iter_mut().zip(p).zip(v).zip(w).zip(forces) {
        *p = *u;
        if w > 0.0 {
            *v = *v * r.keep + (r.gravity + f * w) * r.h;
            *u += *v * r.h;
        }
    }
}

/// A run of tets' constraint solves ([`project`]) in sweep `r.iteration`; the first sweep of
/// a substep clears each tet's multipliers before its solve.
fn solve(
    s: &mut SoftStorage<'_>,
    tets: &[[u32; 4]],
    first: bool,
    inv_h2: f32,
    range: Range<usize>,
) {
    let (Some(tets), Some(rests), Some(lambdas)) = (
        tets.get(range.clone()),
        s.tet_rest.get(range.clone()),
        s.lambdas.get_mut(range),
    ) else {
        return;
    };
    sweep(
        TetRun {
            tets,
            rests,
            lambdas,
        },
        s.displacement,
        s.inv_mass,
        0,
        first,
        inv_h2,
    );
}

/// Tets with their rest data and multipliers, the same length each.
pub(super) struct TetRun<'s> {
    pub(super) tets: &'s [[u32; 4]],
    pub(super) rests: &'s [TetRest],
    pub(super) lambdas: &'s mut [[f32; 2]],
}

/// The tets of `run` solved in order ([`project`]) against the nodes `first_node..` held in
/// `displacement` and `inv_mass` (a node index `k` is slot `k - first_node`); `first` clears
/// each tet's multipliers before its solve (the first sweep of a substep). A tet naming a node
/// outside the slices is skipped (the callers' slices hold every node their tets name).
///
/// Where the target has four-wide f32 arithmetic (x86-64, AArch64), four consecutive tets
/// that share no node are solved at once (`lanes::project4`): the same bits as one after the other,
/// since neither reads a node the other writes. A body ordered so that its tets come in such
/// groups (the host's `SoftOwned::in_lanes`) is swept in about a third of the time; any other
/// order costs one failed check per tet.
///
/// # Bounded work
/// O(tets).
pub(super) fn sweep(
    run: TetRun<'_>,
    displacement: &mut [Vec3],
    inv_mass: &[f32],
    first_node: usize,
    first: bool,
    inv_h2: f32,
) {
    let TetRun {
        tets,
        rests,
        lambdas,
    } = run;
    let n = tets.len().min(rests.len()).min(lambdas.len());
    #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
    let nodes = displacement.len().min(inv_mass.len());
    let mut i = 0;
    while i < n {
        #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
        if let (Some(group), Some(rest), Some(lambda)) = (
            tets.get(i..i + 4),
            rests.get(i..i + 4),
            lambdas.get_mut(i..i + 4),
        ) {
            if let Some(slots) = lanes::disjoint(group, first_node, nodes) {
                lanes::solve4(slots, rest, lambda, displacement, inv_mass, first, inv_h2);
                i += 4;
                continue;
            }
        }
        if let (Some(tet), Some(rest), Some(lambda)) =
            (tets.get(i), rests.get(i), lambdas.get_mut(i))
        {
            solve1(
                tet,
                rest,
                lambda,
                displacement,
                inv_mass,
                first_node,
                first,
                inv_h2,
            );
        }
        i += 1;
    }
}

/// One tet's solve in a sweep ([`sweep`]).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn solve1(
    tet: &[u32; 4],
    rest: &TetRest,
    lambda: &mut [f32; 2],
    displacement: &mut [Vec3],
    inv_mass: &[f32],
    first_node: usize,
    first: bool,
    inv_h2: f32,
) {
    if first {
        *lambda = [0.0; 2];
    }
    let [a, b, c, d] = tet.map(|k| (k as usize).wrapping_sub(first_node));
    let (Some(&ua), Some(&ub), Some(&uc), Some(&ud)) = (
        displacement.get(a),
        displacement.get(b),
        displacement.get(c),
        displacement.get(d),
    ) else {
        return;
    };
    let (Some(&wa), Some(&wb), Some(&wc), Some(&wd)) = (
        inv_mass.get(a),
        inv_mass.get(b),
        inv_mass.get(c),
        inv_mass.get(d),
    ) else {
        return;
    };
    let du = project(rest, [ua, ub, uc, ud], [wa, wb, wc, wd], lambda, inv_h2);
    // In range: read above.
    displacement[a] += du[0];
    displacement[b] += du[1];
    displacement[c] += du[2];
    displacement[d] += du[3];
}

/// A run of nodes' velocities (the end of a substep): a free node's from its displacement
/// change over the substep.
pub(super) fn velocity(s: &mut SoftStorage<'_>, r: &Run, nodes: Range<usize>) {
    let (Some(u), Some(p), Some(v), Some(w)) = (
        s.displacement.get(nodes.clone()),
        s.previous.get(nodes.clone()),
        s.velocity.get_mut(nodes.clone()),
        s.inv_mass.get(nodes),
    ) else {
        return;
    };
    for (((u, p), v), &w) in u.iter().zip(p).zip(v).zip(w) {
        if w > 0.0 {
            *v = (*u - *p) * r.inv_h;
        }
    }
}

impl SoftBody<'_> {
    /// Starts a step of `dt` spread over calls of [`SoftBody::advance`], with the step
    /// parameters of now (a later [`SoftBody::set_params`] applies to the next step).
    /// Refused, nothing changed, when `dt` is not finite and positive or a step is under way.
    ///
    /// # Bounded work
    /// Constant.
    pub fn begin_step(&mut self, dt: f32) -> Result<(), StepError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(StepError::TimeStep);
        }
        if self.run.is_some() {
            return Err(StepError::InProgress);
        }
        let h = dt / self.params.substeps as f32;
        let inv_h = 1.0 / h;
        self.run = Some(Run {
            h,
            inv_h,
            inv_h2: inv_h * inv_h,
            keep: 1.0 / (1.0 + self.params.damping * h),
            gravity: self.params.gravity,
            substeps: self.params.substeps,
            iterations: self.params.iterations,
            substep: 0,
            iteration: 0,
            phase: Phase::Integrate,
            at: 0,
        });
        Ok(())
    }

    /// `true` while a step begun by [`SoftBody::begin_step`] is not complete.
    #[inline]
    pub fn stepping(&self) -> bool {
        self.run.is_some()
    }

    /// Work units of one whole step with the current parameters:
    /// `substeps x (2 N x NODE_UNITS + iterations x T x TET_UNITS)`.
    ///
    /// # Bounded work
    /// Constant.
    pub fn step_units(&self) -> u64 {
        let p = self.params;
        let nodes = 2 * self.rest.len() as u64 * u64::from(NODE_UNITS);
        let tets = u64::from(p.iterations) * self.tets.len() as u64 * u64::from(TET_UNITS);
        u64::from(p.substeps) * (nodes + tets)
    }

    /// Goes on with the step under way: node updates and tet solves in the step's order (per
    /// substep: every node's integration, `iterations` sweeps over the tets, every node's
    /// velocity; [`SoftBody::step`] has the details), each taken only while its units fit in
    /// what is left of
    /// `max_units` (so a call does at most `max_units` units, and nothing when the next
    /// item does not fit: give at least [`TET_UNITS`] to be sure of progress). `external`
    /// is the force per node as in [`SoftBody::step`] and must be the same slice contents
    /// for every call of one step. Without a step under way it does nothing (`done`).
    ///
    /// # Bounded work
    /// At most `max_units` units (a unit is about 37 Cortex-M4 instructions, docs/SOFT.md),
    /// plus the constant cost of the call and of each pass it enters.
    pub fn advance(&mut self, external: &[Vec3], max_units: u32) -> Advance {
        let Some(mut r) = self.run else {
            return Advance {
                units: 0,
                done: true,
            };
        };
        let n = self.rest.len();
        let t = self.tets.len();
        let s = &mut self.s;
        let mut left = max_units;
        loop {
            match r.phase {
                Phase::Integrate => {
                    if r.at >= n {
                        r.phase = Phase::Solve;
                        r.at = 0;
                        r.iteration = 0;
                        continue;
                    }
                    let k = fitting(n - r.at, left, NODE_UNITS);
                    if k == 0 {
                        break;
                    }
                    left -= k as u32 * NODE_UNITS;
                    integrate(s, external, &r, r.at..r.at + k);
                    r.at += k;
                }
                Phase::Solve => {
                    if r.at >= t {
                        r.iteration += 1;
                        r.at = 0;
                        if r.iteration >= r.iterations {
                            r.phase = Phase::Velocity;
                        }
                        continue;
                    }
                    let k = fitting(t - r.at, left, TET_UNITS);
                    if k == 0 {
                        break;
                    }
                    left -= k as u32 * TET_UNITS;
                    solve(s, self.tets, r.iteration == 0, r.inv_h2, r.at..r.at + k);
                    r.at += k;
                }
                Phase::Velocity => {
                    if r.at >= n {
                        r.substep += 1;
                        r.at = 0;
                        r.phase = Phase::Integrate;
                        if r.substep >= r.substeps {
                            self.run = None;
                            return Advance {
                                units: max_units - left,
                                done: true,
                            };
                        }
                        continue;
                    }
                    let k = fitting(n - r.at, left, NODE_UNITS);
                    if k == 0 {
                        break;
                    }
                    left -= k as u32 * NODE_UNITS;
                    velocity(s, &r, r.at..r.at + k);
                    r.at += k;
                }
            }
        }
        self.run = Some(r);
        Advance {
            units: max_units - left,
            done: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::soft::{Material, SoftMesh, SoftParams, SoftStorage, TetRest};

    #[test]
    fn advance_without_a_step_is_done_and_begin_refuses_twice() {
        // Two tets sharing a face.
        let rest = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            Vec3::new(1.0, 1.0, 1.0),
        ];
        let tets = [[0, 1, 2, 3], [1, 4, 2, 3]];
        let (mut u, mut v, mut p) = ([Vec3::ZERO; 5], [Vec3::ZERO; 5], [Vec3::ZERO; 5]);
        let (mut m, mut w) = ([0.0; 5], [0.0; 5]);
        let (mut tr, mut l) = ([TetRest::default(); 2], [[0.0; 2]; 2]);
        let mut b = SoftBody::new(
            SoftMesh {
                rest: &rest,
                tets: &tets,
                tet_material: &[],
            },
            &[Material {
                young: 1e3,
                poisson: 0.3,
                density: 1.0,
            }],
            SoftParams::default(),
            SoftStorage {
                displacement: &mut u,
                velocity: &mut v,
                previous: &mut p,
                mass: &mut m,
                inv_mass: &mut w,
                tet_rest: &mut tr,
                lambdas: &mut l,
            },
        )
        .unwrap();
        assert_eq!(
            b.advance(&[], 100),
            Advance {
                units: 0,
                done: true
            }
        );
        assert_eq!(b.begin_step(0.0), Err(StepError::TimeStep));
        b.begin_step(1e-3).unwrap();
        assert_eq!(b.begin_step(1e-3), Err(StepError::InProgress));
        assert_eq!(b.step(1e-3, &[]), Err(StepError::InProgress));
        // Too little for a tet solve once the nodes are integrated: no progress, no overrun.
        let a = b.advance(&[], TET_UNITS - 1);
        assert_eq!(a.units, 5 * NODE_UNITS);
        assert_eq!(b.advance(&[], TET_UNITS - 1).units, 0);
        let mut total = u64::from(a.units);
        loop {
            let a = b.advance(&[], TET_UNITS);
            total += u64::from(a.units);
            assert!(a.units <= TET_UNITS);
            if a.done {
                break;
            }
        }
        assert_eq!(total, b.step_units());
        assert!(!b.stepping());
    }
}
