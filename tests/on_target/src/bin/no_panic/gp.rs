//! Calls of the Gaussian process.

use super::*;

pub(super) fn gp<T: Real>(rng: &mut ChaCha8Rng) {
    let hyper = Hyperparameters::<T, 3> {
        signal_variance: num(2.0),
        length_scales: [num(1.5), num(2.0), num(1.0)],
        noise_variance: num(0.05),
    };
    keep(Hyperparameters::<T, 3>::SPEC_INITIAL);
    keep(Hyperparameters::<T, 3>::isotropic(
        num(1.0),
        num(2.0),
        num(0.1),
    ));
    keep(hyper.validate());
    let a = [num::<T>(1.0), num(2.0), num(0.0)];
    let b = [num::<T>(0.5), num(2.5), num(1.0)];
    keep(hyper.covariance(&a, &b));

    let mut gp = match Gp::<T, 16, 3>::new(hyper) {
        Ok(gp) => gp,
        Err(_) => Gp::empty(),
    };
    keep(Gp::<T, 16, 3>::default().len());
    keep(Gp::<T, 16, 3>::CAPACITY);
    let mut x = [[T::ZERO; 3]; 12];
    let mut y = [T::ZERO; 12];
    for (i, (xi, yi)) in x.iter_mut().zip(y.iter_mut()).enumerate() {
        let t = T::from_usize(i);
        *xi = [t * num(0.7), num::<T>(10.0) - t, T::from_usize(i % 4)];
        *yi = (t * num(0.3)).exp();
    }
    let n = index(10).min(12);
    keep(gp.fit(opaque(&x[..n]), opaque(&y[..n])));
    keep(gp.add_point(
        b,
        num(0.5),
        if opaque(true) {
            WhenFull::DropOldest
        } else {
            WhenFull::Refuse
        },
    ));
    keep(gp.predict(&a));
    keep(gp.log_marginal_likelihood());
    keep((gp.len(), gp.is_empty(), gp.hyperparameters(), gp.jitter()));
    keep((gp.inputs().len(), gp.targets().len()));
    keep(gp.condition_estimate());
    let policy = awfqi::gp::Conditioning::<T>::DEFAULT.without_base_jitter();
    let policy = policy
        .with_max_jitter_ratio(num(0.01))
        .and_then(|p| p.with_max_condition(num(1e6)))
        .unwrap_or(awfqi::gp::Conditioning::UNBOUNDED);
    keep(gp.set_conditioning(policy));
    keep((
        gp.conditioning().base_jitter(),
        gp.conditioning().allowed_jitter(num(0.1)),
    ));
    keep(gp.set_conditioning(awfqi::gp::Conditioning::DEFAULT));
    keep(gp.set_hyperparameters(Hyperparameters::isotropic(num(1.0), num(1.0), num(0.1))));
    let bounds = HyperparameterBounds::<T, 3>::spec_default();
    keep(bounds.validate());
    keep(bounds.contains(gp.hyperparameters()));
    let options = SearchOptions {
        max_evaluations: index(30),
        restarts: index(2),
        isotropic: opaque(false),
    };
    keep(options.validate());
    keep(SearchOptions::default());
    keep(gp.optimize_hyperparameters(&bounds, &options, rng));
    // Fill to capacity so the sliding-window path of `add_point` is live too.
    for i in 0..index(20) {
        let t = T::from_usize(i);
        keep(gp.add_point([t, t * num(0.5), num(1.0)], t, WhenFull::DropOldest));
    }
    keep(gp.predict(&b));
    gp.clear();
    keep(gp.len());
}
