//! Materials: Young's modulus, Poisson ratio and density, and the elastic constants the
//! XPBD constraints' compliances are derived from.

use core::fmt;

/// An isotropic elastic material in consistent units (for example pascal, kilogram per cubic
/// metre; or the mesh's length unit throughout).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Young's modulus `E` (force per area), finite and positive.
    pub young: f32,
    /// Poisson ratio `nu`, in `[0, 0.49]`.
    pub poisson: f32,
    /// Density (mass per volume), finite and positive.
    pub density: f32,
}

/// Why a [`Material`] is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum MaterialError {
    /// Young's modulus is not finite and positive.
    Young,
    /// The Poisson ratio is outside `[0, 0.49]` (or not finite).
    Poisson,
    /// The density is not finite and positive.
    Density,
}

impl fmt::Display for MaterialError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Young => "Young's modulus must be finite and positive",
            Self::Poisson => "Poisson ratio must be in [0, 0.49]",
            Self::Density => "density must be finite and positive",
        })
    }
}

impl core::error::Error for MaterialError {}

/// Largest Poisson ratio accepted: nearer 0.5 the hydrostatic compliance goes to zero and a
/// fixed number of iterations no longer reaches the incompressible limit.
pub(crate) const MAX_POISSON: f32 = 0.49;

/// The per-volume constants the solver uses for one material.
///
/// The tets' energy density is `mu |dev E|^2 + K/2 (det F - 1)^2` (`E` the Green strain),
/// with the bulk modulus `K = lambda + 2 mu / 3 = hydro - mu / 3`; linearised at `F = I` it
/// is linear elasticity with Lamé constants `(mu, lambda)` (docs/SOFT.md has the
/// derivation). The tet projection takes `mu` and `hydro`: [`super::TetRest::new`] derives
/// the two compliances `1 / (2 mu V)` and `1 / (K V)` from them. It does not use `gamma`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lame {
    /// Shear modulus `mu = E / (2 (1 + nu))`.
    pub mu: f32,
    /// `lambda + mu`, with Lamé `lambda = E nu / ((1 + nu)(1 - 2 nu))`; the tet's bulk
    /// modulus is `hydro - mu / 3`.
    pub hydro: f32,
    /// `1 + mu / hydro`, the rest value of `det F` in the stable neo-Hookean form
    /// `mu/2 tr(F^T F) + hydro/2 (det F - gamma)^2` (Macklin and Mueller 2021). The present
    /// volumetric constraint is `det F - 1` (the rest data's `gamma` is 1, a field kept in
    /// its 52-byte layout), so the projection does not read this value.
    pub gamma: f32,
}

impl Material {
    /// Checks the material's ranges.
    ///
    /// # Bounded work
    /// Constant.
    pub(crate) fn check(&self) -> Result<(), MaterialError> {
        if !(self.young.is_finite() && self.young > 0.0) {
            return Err(MaterialError::Young);
        }
        if !(self.poisson >= 0.0 && self.poisson <= MAX_POISSON) {
            return Err(MaterialError::Poisson);
        }
        if !(self.density.is_finite() && self.density > 0.0) {
            return Err(MaterialError::Density);
        }
        Ok(())
    }

    /// The solver's constants ([`Lame`]) for this material, computed in f64.
    ///
    /// # Bounded work
    /// Constant.
    pub fn lame(&self) -> Lame {
        let e = self.young as f64;
        let nu = self.poisson as f64;
        let mu = e / (2.0 * (1.0 + nu));
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let hydro = lambda + mu;
        Lame {
            mu: mu as f32,
            hydro: hydro as f32,
            gamma: (1.0 + mu / hydro) as f32,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lame_constants_match_textbook_values() {
        // E = 1, nu = 0.25: mu = 0.4, lambda = 0.4, hydro = 0.8, gamma = 1.5.
        let l = Material {
            young: 1.0,
            poisson: 0.25,
            density: 1.0,
        }
        .lame();
        assert!((l.mu - 0.4).abs() < 1e-7);
        assert!((l.hydro - 0.8).abs() < 1e-7);
        assert!((l.gamma - 1.5).abs() < 1e-7);
    }

    #[test]
    fn bad_materials_are_refused() {
        let ok = Material {
            young: 1e5,
            poisson: 0.3,
            density: 1000.0,
        };
        assert_eq!(ok.check(), Ok(()));
        let bad = |m: Material, e| assert_eq!(m.check(), Err(e));
        bad(Material { young: 0.0, ..ok }, MaterialError::Young);
        bad(
            Material {
                young: f32::NAN,
                ..ok
            },
            MaterialError::Young,
        );
        bad(Material { poisson: 0.5, ..ok }, MaterialError::Poisson);
        bad(
            Material {
                poisson: -0.1,
                ..ok
            },
            MaterialError::Poisson,
        );
        bad(
            Material {
                density: f32::INFINITY,
                ..ok
            },
            MaterialError::Density,
        );
    }
}
