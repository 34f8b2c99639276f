#!/usr/bin/env python3
"""Independent evaluation of the IWFQI paper's Dam and Acrobot definitions, for the core's
golden-value tests (tests/iwfqi_domains.rs, which includes the output,
tests/data/iwfqi_domains_golden.rs) — written from the published equations (the
paper's reservoir and multitask-Acrobot models as the reference repository defines them),
not from the Rust code.

  python3 scripts/golden/iwfqi_domains.py > tests/data/iwfqi_domains_golden.rs
                                        the golden values (Rust syntax)
  python3 scripts/golden/iwfqi_domains.py --check DIR
      also replays every record of the published source datasets in DIR
      (dam_source_<k>.csv, acrobot_source_<k>.csv) through these definitions and reports
      the largest deviation (rewards and next states), which checks the definitions
      against the data the paper's results were computed from.

Needs only the standard library (math, csv).
"""
import csv
import math
import sys

# ---------------------------------------------------------------- Dam (water reservoir)
DEMAND, FLOODING, MIN_STORAGE, MAX_STORAGE, INFLOW_STD = 10.0, 300.0, 50.0, 500.0, 2.0
RELEASES = [0.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 30.0]
# Inflow profiles: per third of the year (days 1-120, 121-240, 241-360)
# sin(x * 3 pi / 359 + phase) * mul / div + offset with x = day - 1, then * scale + shift
# (mul / div keep the published order of operations: `sin * 3`, `sin / 4`).
# profile: ([(mul, div, phase, offset)] x3, scale, shift)
PI = math.pi
PROFILES = {
    1: ([(1, 1, 0.0, 0.5), (1, 2, 0.0, 0.5), (1, 1, 0.0, 0.5)], 8.0, 4.0),
    2: ([(1, 2, 0.0, 0.25), (3, 1, PI, 0.25), (1, 4, PI, 0.25)], 8.0, 4.0),
    3: ([(3, 1, 0.0, 0.25), (1, 4, 0.0, 0.25), (1, 2, 0.0, 0.25)], 8.0, 4.0),
    4: ([(1, 1, 0.0, 0.5), (1, 2.5, 0.0, 0.5), (1, 1, 0.0, 0.5)], 7.0, 4.0),
    5: ([(1, 2, -PI / 12, 0.5)] * 3, 8.0, 5.0),
    6: ([(1, 3, PI / 8, 0.5)] * 3, 8.0, 4.0),
    7: ([(1, 1, 0.0, 0.5), (1, 3, 0.0, 0.5), (2, 1, 0.0, 0.5)], 8.0, 5.0),
}
DAM_TARGET = (1, 0.3, 0.7)
DAM_SOURCES = [(2, 0.8, 0.2), (3, 0.35, 0.65), (4, 0.7, 0.3), (5, 0.4, 0.6), (6, 0.6, 0.4),
               (7, 0.45, 0.55)]


def inflow_mean(profile, day):
    """Mean inflow on `day` (1..360)."""
    segments, scale, shift = PROFILES[profile]
    x = day - 1
    mul, div, phase, offset = segments[min(x // 120, 2)]
    return (math.sin(x * 3 * PI / 359 + phase) * mul / div + offset) * scale + shift


def dam_release(storage, action):
    low, high = max(storage - MAX_STORAGE, 0.0), max(storage - MIN_STORAGE, 0.0)
    return min(max(RELEASES[action], low), high)


def dam_reward(instance, storage, action):
    _, alpha, beta = instance
    u = dam_release(storage, action)
    return alpha * (-max(storage - FLOODING, 0.0) / 4) + beta * (-max(DEMAND - u, 0.0) ** 2)


def dam_step(instance, state, action, eps):
    """One step with the standard-normal inflow noise `eps`."""
    profile = instance[0]
    storage, day = state
    u = dam_release(storage, action)
    inflow = inflow_mean(profile, int(day)) + eps * INFLOW_STD
    nxt = [max(storage + inflow - u, 0.0), day + 1 if day < 360 else 1.0]
    return dam_reward(instance, storage, action), nxt


def dam_mean_next_storage(instance, state, action):
    """E[max(m + 2 eps, 0)] with m the noise-free next storage: m Phi(m/2) + 2 phi(m/2)."""
    storage, day = state
    m = storage + inflow_mean(instance[0], int(day)) - dam_release(storage, action)
    z = m / INFLOW_STD
    cdf = 0.5 * (1 + math.erf(z / math.sqrt(2)))
    pdf = math.exp(-z * z / 2) / math.sqrt(2 * PI)
    return m * cdf + INFLOW_STD * pdf


# ---------------------------------------------------------------- Acrobot (multitask)
DT, LC1, LC2, MOI, G = 0.2, 0.5, 0.5, 1.0, 9.8
MAX_VEL_1, MAX_VEL_2 = 4 * PI, 9 * PI
TORQUES = [-2.0, 2.0]
ACRO_TARGET = dict(m1=1.0, m2=1.0, l1=1.0, l2=1.0, task="swing-up")
ACRO_SOURCES = [dict(m1=0.9, m2=0.6, l1=1.1, l2=0.7, task="swing-up"),
                dict(m1=0.95, m2=1.0, l1=0.95, l2=0.95, task="rotate")]


def acro_derivative(p, y, torque):
    """Time derivative of (theta1, theta2, dtheta1, dtheta2): the book's equations."""
    m1, m2, l1 = p["m1"], p["m2"], p["l1"]
    th1, th2, w1, w2 = y
    d1 = m1 * LC1 ** 2 + m2 * (l1 ** 2 + LC2 ** 2 + 2 * l1 * LC2 * math.cos(th2)) + 2 * MOI
    d2 = m2 * (LC2 ** 2 + l1 * LC2 * math.cos(th2)) + MOI
    phi2 = m2 * LC2 * G * math.cos(th1 + th2 - PI / 2)
    phi1 = (-m2 * l1 * LC2 * w2 ** 2 * math.sin(th2)
            - 2 * m2 * l1 * LC2 * w2 * w1 * math.sin(th2)
            + (m1 * LC1 + m2 * l1) * G * math.cos(th1 - PI / 2) + phi2)
    acc2 = ((torque + d2 / d1 * phi1 - m2 * l1 * LC2 * w1 ** 2 * math.sin(th2) - phi2)
            / (m2 * LC2 ** 2 + MOI - d2 ** 2 / d1))
    acc1 = -(d2 * acc2 + phi1) / d1
    return [w1, w2, acc1, acc2]


def wrap(x):
    while x > PI:
        x -= 2 * PI
    while x < -PI:
        x += 2 * PI
    return x


def acro_reward(p, s):
    if p["task"] == "swing-up":
        return -math.cos(s[0]) - math.cos(s[1] + s[0]) - 2.0
    return -abs(s[2] - PI)


def acro_step(p, s, action):
    """(reward, next state, absorbing): one classical RK4 step of length 0.2."""
    torque = TORQUES[action]
    f = lambda y: acro_derivative(p, y, torque)
    h = DT / 2
    k1 = f(s)
    k2 = f([a + h * b for a, b in zip(s, k1)])
    k3 = f([a + h * b for a, b in zip(s, k2)])
    k4 = f([a + DT * b for a, b in zip(s, k3)])
    ns = [a + DT / 6 * (b + 2 * c + 2 * d + e) for a, b, c, d, e in zip(s, k1, k2, k3, k4)]
    ns = [wrap(ns[0]), wrap(ns[1]), min(max(ns[2], -MAX_VEL_1), MAX_VEL_1),
          min(max(ns[3], -MAX_VEL_2), MAX_VEL_2)]
    absorbing = p["task"] == "swing-up" and -math.cos(ns[0]) - math.cos(ns[1] + ns[0]) > 1.0
    return acro_reward(p, s), ns, absorbing


# ---------------------------------------------------------------- golden values
DAM_POINTS = [([200.0, 1.0], 0), ([351.7889265982291, 43.0], 6), ([487.5, 309.0], 2),
              ([55.0, 360.0], 7), ([499.0, 120.0], 4), ([320.0, 240.0], 1), ([0.0, 180.0], 5)]
ACRO_POINTS = [([-1.8, 0.0, 0.0, 0.0], 1), ([0.5, -0.3, 1.0, -2.0], 0),
               ([3.0, 2.5, 12.0, -27.0], 1), ([-3.1, 3.1, -12.5, 28.2], 0),
               ([0.0, 0.0, 0.0, 0.0], 0)]


def golden():
    print("// Generated by scripts/golden/iwfqi_domains.py; do not edit by hand.")
    print("/// Inflow means: (profile, day, mean).")
    print("pub const INFLOW: &[(u8, usize, f64)] = &[")
    for prof in range(1, 8):
        for day in (1, 2, 60, 120, 121, 200, 240, 241, 300, 360):
            print(f"    ({prof}, {day}, {inflow_mean(prof, day)!r}),")
    print("];")
    print("/// Dam: (instance 0 = target, k = source k; state; action; reward; noise-free next")
    print("/// storage m = s + mu - u, before the clip at 0; next day; mean next storage).")
    print("pub const DAM: &[(usize, [f64; 2], usize, f64, f64, f64, f64)] = &[")
    for k, inst in enumerate([DAM_TARGET] + DAM_SOURCES):
        for s, a in DAM_POINTS:
            r = dam_reward(inst, s[0], a)
            m = s[0] + inflow_mean(inst[0], int(s[1])) - dam_release(s[0], a)
            nd = s[1] + 1 if s[1] < 360 else 1.0
            print(f"    ({k}, {s!r}, {a}, {r!r}, {m!r}, {nd!r}, "
                  f"{dam_mean_next_storage(inst, s, a)!r}),")
    print("];")
    print("/// Acrobot: (instance 0 = target, 1, 2 = sources; state; action; reward; next state;")
    print("/// absorbing).")
    print("pub const ACROBOT: &[(usize, [f64; 4], usize, f64, [f64; 4], bool)] = &[")
    for k, p in enumerate([ACRO_TARGET] + ACRO_SOURCES):
        for s, a in ACRO_POINTS:
            r, ns, done = acro_step(p, s, a)
            print(f"    ({k}, {s!r}, {a}, {r!r}, {ns!r}, {str(done).lower()}),")
    print("];")
    # A fixed-policy episode of the target Acrobot: torque +2 while dtheta2 >= 0 else -2,
    # from theta1 = -1.0, until the goal (it is reached) or 100 steps.
    s, ret, steps = [-1.0, 0.0, 0.0, 0.0], 0.0, 0
    for t in range(100):
        a = 1 if s[3] >= 0 else 0
        r, s, done = acro_step(ACRO_TARGET, s, a)
        ret += 0.95 ** t * r
        steps += 1
        if done:
            break
    print("/// The follow-dtheta2 policy's episode on the target Acrobot from theta1 = -1:")
    assert done
    print("/// (steps, discounted return, final state).")
    print(f"pub const ACROBOT_EPISODE: (usize, f64, [f64; 4]) = ({steps}, {ret!r}, {s!r});")
    # The release-10 policy's mean-dynamics year on the target Dam from (200, 1): the
    # storage stays far above 0, so the mean next storage is the noise-free one.
    s, ret, avg, low = [200.0, 1.0], 0.0, 0.0, 200.0
    for t in range(360):
        r, s = dam_step(DAM_TARGET, s, 4, 0.0)
        ret += 0.999 ** t * r
        avg += r
        low = min(low, s[0])
    assert low > 40, low
    print("/// The release-10 policy's year under the mean dynamics on the target Dam from")
    print("/// (200, 1): (discounted return, average reward, final state).")
    print(f"pub const DAM_EPISODE: (f64, f64, [f64; 2]) = ({ret!r}, {avg / 360!r}, {s!r});")


def check(directory):
    worst = {}
    for k, inst in enumerate(DAM_SOURCES, 1):
        with open(f"{directory}/dam_source_{k}.csv") as f:
            for row in csv.DictReader(f):
                s = [float(row["storage"]), float(row["day"])]
                a = RELEASES.index(float(row["a"]))
                r = dam_reward(inst, s[0], a)
                # The noise is not stored: recover it from the next storage and check the
                # day and that it is a plausible standard-normal draw.
                u = dam_release(s[0], a)
                eps = (float(row["next_storage"]) - s[0] + u - inflow_mean(inst[0], int(s[1]))) / 2
                _, ns = dam_step(inst, s, a, eps)
                worst["dam reward"] = max(worst.get("dam reward", 0), abs(r - float(row["r"])))
                worst["dam next day"] = max(worst.get("dam next day", 0),
                                            abs(ns[1] - float(row["next_day"])))
                worst["dam |eps|"] = max(worst.get("dam |eps|", 0), abs(eps))
    for k, p in enumerate(ACRO_SOURCES, 1):
        with open(f"{directory}/acrobot_source_{k}.csv") as f:
            for row in csv.DictReader(f):
                s = [float(row[c]) for c in ("theta1", "theta2", "dtheta1", "dtheta2")]
                r, ns, done = acro_step(p, s, int(float(row["a"])))
                want = [float(row[c]) for c in
                        ("next_theta1", "next_theta2", "next_dtheta1", "next_dtheta2")]
                worst["acrobot reward"] = max(worst.get("acrobot reward", 0),
                                              abs(r - float(row["r"])))
                worst["acrobot next state"] = max(worst.get("acrobot next state", 0),
                                                  max(abs(x - y) for x, y in zip(ns, want)))
                if done != (float(row["absorbing"]) != 0):
                    worst["acrobot absorbing mismatches"] = worst.get(
                        "acrobot absorbing mismatches", 0) + 1
    for name, v in worst.items():
        print(f"{name}: {v!r}")


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--check":
        check(sys.argv[2])
    else:
        golden()
