//! Calls of the core's basics: generator adapters, errors and floats, generators and
//! policies.

use super::*;

/// The generator adapters of older `rand_core` versions over the caller's ChaCha8.
pub(super) fn generator_adapters(rng: &mut ChaCha8Rng) {
    struct Old<'a>(&'a mut ChaCha8Rng);
    impl rand_core_06::RngCore for Old<'_> {
        fn next_u32(&mut self) -> u32 {
            rand_core::Rng::next_u32(self.0)
        }
        fn next_u64(&mut self) -> u64 {
            rand_core::Rng::next_u64(self.0)
        }
        fn fill_bytes(&mut self, dst: &mut [u8]) {
            rand_core::Rng::fill_bytes(self.0, dst)
        }
        fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), rand_core_06::Error> {
            rand_core::Rng::fill_bytes(self.0, dst);
            Ok(())
        }
    }
    impl rand_core_09::RngCore for Old<'_> {
        fn next_u32(&mut self) -> u32 {
            rand_core::Rng::next_u32(self.0)
        }
        fn next_u64(&mut self) -> u64 {
            rand_core::Rng::next_u64(self.0)
        }
        fn fill_bytes(&mut self, dst: &mut [u8]) {
            rand_core::Rng::fill_bytes(self.0, dst)
        }
    }
    let mut bytes = [0u8; 5];
    let mut six = awfqi::rng::compat::Rng06(Old(&mut *rng));
    keep((
        awfqi::rng::uniform::<f32, _>(&mut six),
        rand_core::Rng::next_u32(&mut six),
    ));
    rand_core::Rng::fill_bytes(&mut six, &mut bytes);
    let mut nine = awfqi::rng::compat::Rng09(Old(&mut *rng));
    keep((
        awfqi::rng::uniform::<f64, _>(&mut nine),
        rand_core::Rng::next_u32(&mut nine),
    ));
    rand_core::Rng::fill_bytes(&mut nine, &mut bytes);
    keep(bytes);
}

pub(super) fn error_and_float<T: Real>() {
    // `Error`'s Display goes through core::fmt; it is covered by writing into a sink.
    let errors = [
        awfqi::Error::CapacityExceeded { capacity: index(3) },
        awfqi::Error::BufferTooSmall {
            buffer: "b",
            capacity: index(3),
            needed: index(4),
        },
        awfqi::Error::NonFinite { parameter: "x" },
        awfqi::Error::InvalidParameter { parameter: "y" },
        awfqi::Error::OutOfRange { parameter: "z" },
        awfqi::Error::EmptyData,
        awfqi::Error::NotPositiveDefinite,
        awfqi::Error::JitterLimit {
            needed: awfqi::Number(opaque(1e-6)),
            allowed: awfqi::Number(opaque(1e-9)),
        },
        awfqi::Error::IllConditioned {
            condition: awfqi::Number(opaque(1e9)),
            limit: awfqi::Number(opaque(8e4)),
        },
    ];
    let e = errors
        .get(index(2))
        .copied()
        .unwrap_or(awfqi::Error::EmptyData);
    keep(core::fmt::write(&mut Sink, format_args!("{e}")));

    let x: T = num(0.3);
    keep((x.sqrt(), x.exp(), x.ln(), x.ln_1p(), x.abs(), x.floor()));
    keep((x.max(num(0.1)), x.min(num(0.1)), x.is_finite(), x.is_nan()));
    keep((
        x.squared(),
        x.clamp_to(num(0.0), num(1.0)),
        x.to_f64(),
        T::from_usize(index(7)),
    ));
    keep(awfqi::float::log_add_exp(x, num(2.0)));
    keep(awfqi::float::log_sum_exp(opaque(
        &[x, num(1.0), num(-3.0)][..],
    )));
}

pub(super) fn rng_and_policy<T: Real>(rng: &mut ChaCha8Rng) {
    keep(awfqi::rng::uniform_f64(rng));
    keep(awfqi::rng::uniform::<T, _>(rng));
    keep(awfqi::rng::uniform_in::<T, _>(rng, num(-1.0), num(2.0)));
    keep(awfqi::rng::standard_normal::<T, _>(rng));
    keep(awfqi::rng::uniform_index(rng, index(8)));
    keep(awfqi::rng::normal::<T, _>(rng, num(1.0), num(0.5)));
    let weights: [T; 4] = [num(0.0), num(1.0), num(2.0), num(0.5)];
    keep(awfqi::rng::categorical(rng, opaque(&weights[..])));

    if let Ok(mut uniform) = UniformPolicy::new(index(4)) {
        keep(uniform.num_actions());
        keep(Policy::<[T; 2]>::action(
            &mut uniform,
            &[num(1.0), num(2.0)],
            rng,
        ));
    }
    let greedy = |s: &[T; 2]| -> awfqi::Result<usize> { Ok(usize::from(s[0] > s[1])) };
    if let Ok(mut policy) = EpsilonGreedyPolicy::new(greedy, num::<T>(0.3), index(4)) {
        keep(policy.epsilon());
        keep(policy.action(&[num(1.0), num(2.0)], rng));
        keep(policy.greedy());
        keep(policy.greedy_mut());
        let inner = policy.into_greedy();
        keep(inner(&[num(1.0), num(0.0)]));
    }
}
