//! The GP's linear algebra two ways, for the code-size comparison of docs/footprint.md ("Why the
//! hand-written Cholesky"): the core's [`Gp`] (fit = kernel fill + Cholesky + solve, then a
//! prediction) and the same job with nalgebra's fixed-size `Cholesky` (no default features,
//! as the core would use it). Built and sized by `scripts/cholesky-size`; each image of
//! `src/bin/compare/` runs one variant at one capacity (24) or two (24 and 64, where
//! nalgebra's fixed-size code is generated once per capacity and the core's once).

use awfqi::gp::{Gp, Hyperparameters};
use awfqi::{Error, Result};
use nalgebra::{Cholesky, SMatrix, SVector};

/// Signal variance, length scale, noise variance of both variants.
const HYPER: (f32, f32, f32) = (1.0, 1.5, 0.05);

/// The `i`-th input: a spiral in the plane, the action as the third coordinate.
fn point(i: usize) -> [f32; 3] {
    let t = i as f32;
    [
        5.0 + 4.0 * libm::sinf(t * 0.37),
        5.0 + 4.0 * libm::cosf(t * 0.11),
        (i % 4) as f32,
    ]
}

/// Input and target of point `i`.
fn data(i: usize) -> ([f32; 3], f32) {
    let x = point(i);
    (x, libm::sinf(x[0]) + 0.1 * x[1])
}

/// The core: fits `gp` on the first `N` points, predicts at `at`; mean + variance.
pub fn core_job<const N: usize>(gp: &mut Gp<f32, N, 3>, at: [f32; 3]) -> Result<f32> {
    let (c, l, s) = HYPER;
    gp.clear();
    gp.set_hyperparameters(Hyperparameters::isotropic(c, l, s))?;
    for i in 0..N {
        let (x, y) = data(i);
        gp.add_point(x, y, awfqi::gp::WhenFull::Refuse)?;
    }
    let p = gp.predict(&at)?;
    Ok(p.mean + p.latent_variance)
}

/// nalgebra: fills `k` with the kernel matrix of the first `N` points plus the noise,
/// factorises it, solves for the mean weights and the variance; mean + variance.
pub fn nalgebra_job<const N: usize>(k: &mut SMatrix<f32, N, N>, at: [f32; 3]) -> Result<f32> {
    let (c, l, s) = HYPER;
    let kernel = |a: &[f32; 3], b: &[f32; 3]| -> f32 {
        let d: f32 = a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum();
        c * libm::expf(-0.5 * d / (l * l))
    };
    let mut y = SVector::<f32, N>::zeros();
    let mut kstar = SVector::<f32, N>::zeros();
    for i in 0..N {
        let (xi, yi) = data(i);
        y[i] = yi;
        kstar[i] = kernel(&xi, &at);
        for j in 0..N {
            k[(i, j)] = kernel(&xi, &data(j).0) + if i == j { s + 1e-10 } else { 0.0 };
        }
    }
    let chol = Cholesky::new(*k).ok_or(Error::NotPositiveDefinite)?;
    let alpha = chol.solve(&y);
    let mean = kstar.dot(&alpha);
    let mut v = kstar;
    if !chol.l_dirty().solve_lower_triangular_mut(&mut v) {
        return Err(Error::NotPositiveDefinite);
    }
    Ok(mean + (c - v.norm_squared()).max(0.0))
}
