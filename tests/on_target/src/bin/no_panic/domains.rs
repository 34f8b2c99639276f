//! Calls of the domains: Grid World, Puddle World, Dam, Acrobot.

use super::*;

pub(super) fn grid<T: Real>(rng: &mut ChaCha8Rng) {
    let candidates = GridWorld::<T>::thesis_candidates(opaque(true));
    let world = match GridWorld::<T>::new(
        index(10),
        index(10),
        (index(3), index(4)),
        num(0.25),
        opaque(false),
    ) {
        Ok(w) => w,
        Err(_) => candidates[0],
    };
    keep(GridWorld::<T>::thesis(index(2), opaque(false)));
    keep((
        world.width(),
        world.height(),
        world.goal(),
        world.absorbing_goal(),
    ));
    keep(world.state_of(index(3), index(5)));
    keep(world.cell_of(index(37)));
    keep(world.next_state(index(37), index(2)));
    keep((
        FiniteMdp::num_states(&world),
        FiniteMdp::num_actions(&world),
        world.initial_state(),
    ));
    keep(world.transition_probability(index(3), index(1), index(2)));
    let mut total = T::ZERO;
    keep(world.for_each_successor(index(5), index(0), |s, p| {
        total += p * T::from_usize(s);
    }));
    keep(total);
    keep(world.reward_mean(index(99), index(0)));
    keep(world.reward_variance(index(9), index(3)));
    keep(GenerativeModel::num_actions(&world));
    keep(world.query(index(44), index(1), rng));
}

pub(super) fn puddle<T: Real>(rng: &mut ChaCha8Rng) {
    let dynamics = if opaque(true) {
        Dynamics::PuddleBased
    } else {
        Dynamics::Shared
    };
    keep(dynamics.slow_down());
    let puddles = [
        Puddle::new([num::<T>(1.0), num(4.0)], num(0.7)),
        Puddle::new([num(6.0), num(6.0)], num(0.8)),
    ];
    let custom = PuddleWorld::new([num(5.0), num(10.0)], opaque(&puddles[..]), dynamics);
    let [s1, s2, s3] = PuddleWorld::<T>::sources(dynamics);
    let worlds = [
        PuddleWorld::<T>::target(dynamics),
        s1,
        s2,
        s3,
        PuddleWorld::source_1(dynamics),
    ];
    keep((
        PuddleWorld::<T>::source_2(dynamics),
        PuddleWorld::<T>::source_3(dynamics),
    ));
    let world = match custom {
        Ok(w) => w,
        Err(_) => worlds[index(3) % 5],
    };
    keep((
        world.goal(),
        world.dynamics(),
        world.slow_down(),
        world.num_puddles(),
    ));
    let mut sum = T::ZERO;
    for p in world.puddles() {
        sum += p.variance + p.mean[0];
    }
    keep(sum);
    let s = [num::<T>(3.0), num(4.5)];
    keep(world.initial_state());
    keep(world.check_state(s));
    keep(world.puddle_weight(s));
    keep(world.step_length(s));
    keep(world.in_goal(s));
    keep(world.mean_reward(s));
    keep(world.mean_next_state(s, index(2)));
    keep(world.step(s, index(1), rng));
    keep(GenerativeModel::num_actions(&world));
    keep(world.query(s, index(3), rng));

    let mut uniform = UniformPolicy::new(4).unwrap_or_else(|_| loop {});
    let mut count = 0usize;
    keep(world.run_episode_with(&mut uniform, index(50), rng, |r| {
        count += r.t;
        Ok(())
    }));
    keep(count);
    let mut records = [EpisodeRecord::<T>::default(); 50];
    keep(world.run_episode(&mut uniform, index(50), &mut records, rng));
    keep(&records);
    keep(world.rollout(&mut uniform, index(50), num(0.99), rng));
}

pub(super) fn dam<T: Real>(rng: &mut ChaCha8Rng) {
    let profile = InflowProfile::new(opaque(3)).unwrap_or_else(|_| loop {});
    keep((profile.index(), profile.mean(index(200))));
    let custom = Dam::new(profile, num::<T>(0.4), num(0.6));
    let sources = Dam::<T>::sources();
    let env = match custom {
        Ok(d) => d,
        Err(_) => sources[index(2) % 6],
    };
    keep((
        Dam::<T>::target(),
        env.profile(),
        env.flooding_weight(),
        env.demand_weight(),
    ));
    let s = [num::<T>(320.0), num(17.0)];
    keep(env.check_state(s));
    keep(env.inflow_mean(s));
    keep(env.release(s, index(5)));
    keep(env.mean_reward(s, index(1)));
    keep(env.mean_next_state(s, index(7)));
    keep(env.step(s, index(3), rng));
    keep(env.initial_state(rng));
    keep(GenerativeModel::num_actions(&env));
    keep(env.query(s, index(6), rng));
}

pub(super) fn acrobot<T: Real>(rng: &mut ChaCha8Rng) {
    let task = if opaque(true) {
        AcrobotTask::SwingUp
    } else {
        AcrobotTask::Rotate
    };
    let custom = Acrobot::new([num::<T>(0.9), num(0.6)], [num(1.1), num(0.7)], task);
    let sources = Acrobot::<T>::sources();
    let env = match custom {
        Ok(a) => a,
        Err(_) => sources[index(1) % 2],
    };
    keep((
        Acrobot::<T>::target(),
        env.masses(),
        env.lengths(),
        env.task(),
    ));
    let s = [num::<T>(0.4), num(-1.2), num(3.0), num(-7.5)];
    keep(env.check_state(s));
    keep(env.mean_reward(s));
    keep(env.in_goal(s));
    keep(env.mean_next_state(s, index(1)));
    keep(env.step(s, index(0)));
    keep(env.initial_state(rng));
    keep(GenerativeModel::num_actions(&env));
    keep(env.query(s, index(1), rng));
}
