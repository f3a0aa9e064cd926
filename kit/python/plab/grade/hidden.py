"""Hidden scenes of `plab grade`, drawn from the grading's secret seed.

Two kinds: the rubric's random scenes (`plab gen ... --seed`, as before), and scenes from the same
FAMILIES as the public hand-made edge cases (events exactly at a step's end or start, ties, exact
corner hits, grazing, disks resting on walls, overlapping starts, coincident centres, Newton's
cradles, dense lattices) with fresh positions, speeds, sizes, counts, box sizes, walls and particle
order. Random real-valued scenes never put an event exactly at t = 1, never tie two events and
never rest a disk on a wall; these do, so a submission tuned to the public files alone does not
pass them for free.

Every family scene uses small integers and dyadic fractions (halves, quarters) only, so every
quantity of the designed event is exact in double arithmetic (the exact arithmetic is written
next to each family below). Most groups of particles move along one axis in their own lane
(lanes at least 2r + 1 apart, no velocity across them), so several groups share one scene without
meeting. After drawing a scene, each designed event is checked with the kit's reference program
(`--explain STEP:i,... --json`, its event times as doubles): the scene is drawn again (from the
same seed, next attempt) if any is not exactly as designed, so every returned scene really
exercises its edge. No physics is computed here (no event time, no collision): the kit's C++
does it. Expected outputs are never made here: the grader computes them with the reference at
grading time.
The reference's events file is read by the kit's own reader (`plab read`, plab.plabio).

  PYTHONPATH=kit/python python3 -m plab.grade.hidden --seed S --stage NN --only hidden-ties \
      --out hidden.in
"""
import argparse
import json
import pathlib
import random
import subprocess
import sys
from fractions import Fraction

from plab import KIT, plabio  # the kit's source folder; its formats and programs

# Fractions of a step at which designed events happen: exact in binary.
T_INSIDE = (Fraction(1, 4), Fraction(1, 2), Fraction(3, 4))
ATTEMPTS = 40


class Group:
    """Particles moving along x in lanes (y offsets from the group's lane), with checks.

    parts: [x, lane offset, vx, vy] as Fractions (vy is 0 except in 2D scenes);
    checks: [(step, local index, kind, local partner, t)], kind "wall", "pair", "free", "nopair"
    (the loser of a tie: free or hitting its own wall later) or "tie" (pairs at the same t whose
    winner is decided by the indices: partner is the list of rival pairs)."""

    def __init__(self):
        self.parts, self.checks = [], []
        self.anchored = False  # designed against the left wall (x = r is the wall's contact)

    def add(self, x, vx, lane=0, vy=0):
        self.parts.append([Fraction(x), Fraction(lane), Fraction(vx), Fraction(vy)])
        return len(self.parts) - 1

    def span(self):
        xs = [p[0] for p in self.parts]
        return min(xs), max(xs)

    def lanes(self):
        return [p[1] for p in self.parts]


def back(g, m):
    """Moves every particle of g back m free steps: the designed state is the one at the start of
    step m (x - m vx is exact for dyadic x and vx)."""
    for p in g.parts:
        p[0] -= m * p[2]
        p[1] -= m * p[3]
    g.checks = [(s + m,) + c[1:] for c in g.checks for s in [c[0]]]
    return g


def mirror_x(g, L):
    """x -> L - x, vx -> -vx: the right wall instead of the left (exact: L and x are dyadic)."""
    for p in g.parts:
        p[0], p[2] = L - p[0], -p[2]
    return g


def speed(rng, lo=1, hi=3, halves=True):
    v = Fraction(rng.randint(lo, hi))
    if halves and rng.random() < 0.3:
        v += Fraction(1, 2)
    return v


# -- families: each returns (L, r, steps, groups, free_2d) --------------------------------------------
# Lengths below: r is the radius, gap = distance between disk surfaces, s = closing speed.
# Head-on or chasing pair along x (lane 0): dx = -(2r + gap), dv = s, so
#   c = (2r + gap)^2 - 4r^2, b = -2(2r + gap)s, a = s^2, D = b^2 - 4ac = 16 s^2 r^2,
#   sqrt(D) = 4sr, t1 = (2(2r + gap)s - 4sr) / (2s^2) = gap / s:
# every term a small dyadic number, so exact; gap = s t with t dyadic makes t1 = t exactly.
# Wall along x at the left: t = (x - r) / (0 - vx), exact when x - r = |vx| t.

def lane_pair(g, x0, u, w, t, r, chase=False):
    """Two disks meeting at exactly t (gap = s t): the left at x0 with +u; the right with -w, or
    with +w < u when chasing. Returns (left, right) local indices."""
    s = (u - w) if chase else (u + w)
    a = g.add(x0, u)
    b = g.add(x0 + 2 * r + s * t, w if chase else -w)
    return a, b


def fam_step_end(rng, r):
    """Events at exactly t = 1 (they belong to the next step, at its t = 0): a head-on pair, a
    chasing pair (gap = s), a wall hit (x - r = |vx|)."""
    groups = []
    for kind in rng.sample(["head", "chase", "wall", "head", "wall"], rng.randint(3, 5)):
        g, m = Group(), rng.randint(0, 3)
        if kind == "wall":
            v = speed(rng)
            i = g.add(r + v, -v)
            g.anchored = True
            g.checks = [(0, i, "free", None, None), (1, i, "wall", None, Fraction(0))]
        else:
            u, w = speed(rng, 2, 3), speed(rng, 1, 2) if kind == "chase" else speed(rng)
            if kind == "chase" and w >= u:
                w = u - 1
            i, j = lane_pair(g, 0, u, w, Fraction(1), r, chase=kind == "chase")
            g.checks = [(0, i, "free", None, None), (0, j, "free", None, None),
                        (1, i, "pair", j, Fraction(0)), (1, j, "pair", i, Fraction(0))]
        groups.append(back(g, m))
    return groups


def fam_step_start(rng, r):
    """Events at exactly t = 0 from the start state (step 0): a disk touching a wall and moving
    into it (x - r = 0: t = 0 / |vx| = +0), a touching pair approaching (gap 0: t1 = 0 is not > 0,
    t2 = 2|b| / 2a > 0: t = 0), a touching pair separating (b > 0: t1 < 0, t2 = 0: no event),
    and a touching disk moving into a wall while its touching partner approaches (a wall and a
    pair at t = 0: the wall wins)."""
    groups = []
    for kind in rng.sample(["wall", "approach", "separate", "both", "approach"], rng.randint(3, 5)):
        g = Group()
        u, w = speed(rng), speed(rng)
        g.anchored = kind in ("wall", "both")
        if kind == "wall":
            i = g.add(r, -u)
            g.checks = [(0, i, "wall", None, Fraction(0))]
        elif kind == "approach":
            i, j = g.add(0, u), g.add(2 * r, -w)
            g.checks = [(0, i, "pair", j, Fraction(0)), (0, j, "pair", i, Fraction(0))]
        elif kind == "separate":
            i, j = g.add(0, -u), g.add(2 * r, w)
            g.checks = [(0, i, "free", None, None), (0, j, "free", None, None)]
        else:
            i, j = g.add(r, -u), g.add(3 * r, -(u + w))
            g.checks = [(0, i, "wall", None, Fraction(0)), (0, j, "nopair", None, None)]
        groups.append(g)
    return groups


def fam_ties(rng, r):
    """Ties at a dyadic t in (0, 1): a wall and a pair of the same particle (x - r = u t, the
    chaser's gap = (w - u) t: the wall wins, kind 0 before 1), and two pairs sharing a middle disk
    (gaps (uL - vM) t and (uR + vM) t: the pair with the lower (lo, hi) wins). Every draw holds a
    wall-and-pair tie whose pair has the lower index (draw()), which only the key's kind decides."""
    groups = []
    for kind in [rng.choice(["wall-pair", "shared"]) for _ in range(rng.randint(4, 7))]:
        g, m, t = Group(), rng.randint(0, 2), rng.choice(T_INSIDE)
        if kind == "wall-pair":
            u = speed(rng, 1, 2)
            w = u + speed(rng, 1, 2)
            i = g.add(r + u * t, -u)
            g.anchored = True
            j = g.add(r + u * t + 2 * r + (w - u) * t, -w)
            # "kind": the wall of i and the pair (i, j) tie; the draw keeps one where j < i
            g.checks = [(0, i, "wall", None, t), (0, j, "nopair", None, None), (0, i, "kind", j, t)]
        else:
            vm = rng.choice([Fraction(0), Fraction(1, 2), Fraction(-1, 2)])
            ul, ur = speed(rng, 1, 3), speed(rng, 1, 3)
            left = g.add(0, ul)
            mid = g.add(2 * r + (ul - vm) * t, vm)
            right = g.add(2 * r + (ul - vm) * t + 2 * r + (ur + vm) * t, -ur)
            g.checks = [(0, None, "tie", [(left, mid), (mid, right)], t)]
        groups.append(back(g, m))
    return groups


def fam_grazing(rng, r):
    """Tangent paths: lanes exactly 2r apart, closing speed s, x distance d = s t:
    Delta = (-d, -2r), c = d^2 + 4r^2 - 4r^2 = d^2, b = -2ds, a = s^2, D = 4d^2s^2 - 4s^2d^2 = 0
    exactly, t1 = 2ds / 2s^2 = t: a grazing collision (counted, velocities unchanged). Next to it a
    pair with lanes 2r + 2^-k apart, which misses (D < 0)."""
    groups = []
    for kind in rng.sample(["graze", "graze", "miss", "graze"], rng.randint(2, 4)):
        g, m, t = Group(), rng.randint(0, 3), rng.choice(T_INSIDE + (Fraction(1, 8),))
        u, w = speed(rng), speed(rng)
        lane = 2 * r + (Fraction(1, 2 ** rng.randint(4, 12)) if kind == "miss" else 0)
        i = g.add(0, u)
        j = g.add((u + w) * t, -w, lane=lane)
        if kind == "graze":
            g.checks = [(0, i, "pair", j, t), (0, j, "pair", i, t)]
        else:
            g.checks = [(0, i, "free", None, None), (0, j, "free", None, None)]
        groups.append(back(g, m))
    return groups


def fam_resting(rng, r):
    """Disks resting on a wall: lanes at y = r or y = L - r exactly with vy = 0 (the wall time
    along y is +inf, not 0/0), moving along the wall or at rest; and a disk at rest touching a side
    wall (x = r) hit by another at t (gap = u t): it takes -u, stays at x = r ((x - r)/u = 0 of
    the rest of the step) and hits the wall at t = 0 of the next step."""
    groups = []
    for kind in ["floor", "ceiling", "pushed"] + rng.sample(["floor", "ceiling", "pushed"], 1):
        g = Group()
        if kind == "pushed":
            m, t, u = rng.randint(0, 2), rng.choice(T_INSIDE), speed(rng)
            i = g.add(r, 0)
            g.anchored = True
            j = g.add(3 * r + u * t, -u)
            g.checks = [(m, i, "pair", j, t), (m, j, "pair", i, t), (m + 1, i, "wall", None, 0)]
            for p in g.parts[1:]:
                p[0] += m * u
        else:
            g.wall_lane = kind
            n = rng.randint(1, 3)
            for x in sorted(rng.sample(range(0, 12), n)):
                v = rng.choice([0, 0, 1, -1, Fraction(1, 2), 2])
                g.add(Fraction(x) * (2 * r + 1), v)
        groups.append(g)
    return groups


def fam_overlap(rng, r):
    """Pairs overlapping at the start by q in {1/4, 1/2, 1, 3/2} (distance 2r - q): approaching or
    separating, both collide at t = 0 (c < 0, so t1 < 0 < t2); with equal velocities a = 0 and no
    event."""
    groups = []
    for kind in rng.sample(["in", "out", "same", "in", "out"], rng.randint(3, 5)):
        g = Group()
        q = rng.choice([Fraction(1, 4), Fraction(1, 2), Fraction(1), Fraction(3, 2)]) * r
        u, w = speed(rng), speed(rng)
        if kind == "in":
            i, j = g.add(0, u), g.add(2 * r - q, -w)
        elif kind == "out":
            i, j = g.add(0, -u), g.add(2 * r - q, w)
        else:
            i, j = g.add(0, u), g.add(2 * r - q, u)
        if kind == "same":
            g.checks = [(0, i, "free", None, None), (0, j, "free", None, None)]
        else:
            g.checks = [(0, i, "pair", j, Fraction(0)), (0, j, "pair", i, Fraction(0))]
        groups.append(g)
    return groups


def fam_coincident(rng, r):
    """Two disks with the same centre and different velocities: Delta = 0, c = -4r^2, b = 0,
    D = 16 a r^2 > 0, t1 < 0 < t2: the pair is chosen at t = 0 but has no normal, so it is dropped
    and both move freely, uncounted; also the same centre at rest for one of them."""
    groups = []
    for _ in range(rng.randint(2, 4)):
        g = Group()
        u = speed(rng)
        w = rng.choice([-speed(rng), Fraction(0), u + 1])
        i, j = g.add(0, u), g.add(0, w)
        g.checks = [(0, i, "pair", j, Fraction(0)), (0, j, "pair", i, Fraction(0))]
        groups.append(g)
    return groups


def fam_cradle(rng, r):
    """Newton's cradles: k disks touching at rest (centres exactly 2r apart: a = 0, no event
    between them), struck at a dyadic t by a disk from one side (gap = u t) or from both sides;
    or with gaps of r/4 between them."""
    groups = []
    for kind in rng.sample(["one", "two", "gaps"], rng.randint(2, 3)):
        g, m, t = Group(), rng.randint(0, 2), rng.choice(T_INSIDE)
        k, u = rng.randint(3, 5), speed(rng)
        spacing = 2 * r + (r / 4 if kind == "gaps" else 0)
        s = g.add(0, u)
        first = g.add(2 * r + u * t, 0)
        last = first
        for n in range(1, k):
            last = g.add(g.parts[first][0] + n * spacing, 0)
        g.checks = [(0, s, "pair", first, t)]
        if kind == "two":
            w = speed(rng)
            e = g.add(g.parts[last][0] + 2 * r + w * t, -w)
            g.checks.append((0, e, "pair", last, t))
        groups.append(back(g, m))
    return groups


FAMILIES = {
    "hidden-step-end": fam_step_end,
    "hidden-step-start": fam_step_start,
    "hidden-ties": fam_ties,
    "hidden-grazing": fam_grazing,
    "hidden-resting": fam_resting,
    "hidden-overlap": fam_overlap,
    "hidden-coincident": fam_coincident,
    "hidden-cradle": fam_cradle,
}
# 2D families (not lanes): exact corner hits, dense lattices, disks hit from two sides at once
TWO_D = ("hidden-corners", "hidden-lattice", "hidden-converging")


def corners(rng):
    """Exact corner hits: a disk with velocity (-a, -b) at x = r + aT, y = r + bT reaches both
    walls at exactly T (t_x = aT / a = T = t_y): both axes reflect. T = m + t with t in
    {0, 1/4, 1/2, 3/4, 1}: at a step start, inside a step, at a step's end. One disk per corner
    (mirrored), so they meet only after their corner hits."""
    r = rng.choice([Fraction(1), Fraction(1, 2), Fraction(3, 2)])
    L = Fraction(rng.randint(24, 40))
    parts, checks = [], []
    for cx, cy in rng.sample([(0, 0), (1, 0), (0, 1), (1, 1)], rng.randint(2, 4)):
        a, b = speed(rng, 1, 2, False), speed(rng, 1, 2, False)
        m, t = rng.randint(0, 2), rng.choice((Fraction(0),) + T_INSIDE + (Fraction(1),))
        T = m + t
        x, y, vx, vy = r + a * T, r + b * T, -a, -b
        if cx:
            x, vx = L - x, -vx
        if cy:
            y, vy = L - y, -vy
        i = len(parts)
        parts.append([x, y, vx, vy])
        if t == 1:
            checks += [(m, i, "free", None, None), (m + 1, i, "wall", None, Fraction(0))]
        else:
            checks.append((m, i, "wall", None, t))
    return L, r, parts, checks


# The directions of a 3-4-5 triangle (and the axes), times 5: integer vectors of length 5.
FIVE = [(3, 4), (4, 3), (-3, 4), (-4, 3), (3, -4), (4, -3), (-3, -4), (-4, -3),
        (5, 0), (0, 5), (-5, 0), (0, -5)]


def converging(rng):
    """Disks at rest each hit at exactly the same dyadic t by two or three disks coming head-on
    along lines of centres at angles between 61 and 164 degrees (never 90 or 180). In continuous
    time the hits happen one after the other at that instant, and their order changes the result
    (exchanges along two lines of centres that are neither parallel nor perpendicular do not
    commute): the queue's key, time and then the particle's index, decides it. In the stepped
    model the pair with the lower (lo, hi) wins the tie. A hitter with direction u (|u| = 5) and
    speed 5q starts at B - u m, m = 2r/5 + q t (r = 5/2 or 5/4: 2r/5 is dyadic), so
      c = (5m)^2 - 4r^2 = 5qt (4r + 5qt), b = -25 m q, a = 25 q^2, b^2 - ac = 100 q^2 r^2,
    sqrt = 10 q r, and t1 = (25 m q - 10 q r) / (25 q^2) = t: every term a small dyadic number.
    Two hitters' lines at least 61 degrees apart keep them 2r apart all the way in."""
    r = rng.choice([Fraction(5, 2), Fraction(5, 4)])
    pitch = 2 * (2 * r + 2 * 5 * 2 + 2 * 5) + 2 * r  # a group's reach, a step back included
    cols = rng.choice((3, 4))
    L = pitch * cols + rng.randint(0, 4)
    parts, checks = [], []
    for gx, gy in rng.sample([(x, y) for x in range(cols) for y in range(cols)], rng.randint(5, 9)):
        cx, cy = pitch * gx + pitch / 2, pitch * gy + pitch / 2
        m, t = rng.randint(0, 1), rng.choice(T_INSIDE)
        hitters = []
        for u in rng.sample(FIVE, len(FIVE)):
            dots = [u[0] * h[0] + u[1] * h[1] for h in hitters]
            if all(d <= 12 and d not in (0, -25) for d in dots):
                hitters.append(u)
            if len(hitters) == rng.choice((2, 3)):
                break
        if len(hitters) < 2:
            raise ValueError("fewer than two directions apart")
        b = len(parts)
        parts.append([cx, cy, Fraction(0), Fraction(0)])
        pairs = []
        for ux, uy in hitters:
            q = speed(rng, 1, 2)
            d = 2 * r / 5 + q * t + m * q  # m steps back
            parts.append([cx - ux * d, cy - uy * d, ux * q, uy * q])
            pairs.append((len(parts) - 1, b))
        checks.append((m, None, "tie", pairs, t))
    return L, r, parts, checks


def dense(rng):
    """A dense lattice: disks on integer grid points 2r + 1 apart (or 2r: touching) in a small
    box, velocities in {-1, -1/2, 0, 1/2, 1} per axis. Many events tie exactly (same-speed
    pairs along an axis, walls at t = 1/2 and 1), competing for the same disks."""
    r = Fraction(1)
    pitch = rng.choice([Fraction(2), Fraction(5, 2), Fraction(3)])
    cols = rng.randint(4, 6)
    L = pitch * cols + rng.choice([0, 1, 2])
    vs = [Fraction(-1), Fraction(-1, 2), Fraction(0), Fraction(1, 2), Fraction(1)]
    parts = []
    for gx in range(cols):
        for gy in range(cols):
            x, y = r + gx * pitch, r + gy * pitch
            if x <= L - r and y <= L - r and rng.random() < 0.8:
                parts.append([x, y, rng.choice(vs), rng.choice(vs)])
    return L, r, parts, []


def lanes_scene(rng, family):
    r = rng.choice([Fraction(1), Fraction(1), Fraction(1, 2), Fraction(3, 2)])
    groups = FAMILIES[family](rng, r)
    widths = []
    for g in groups:
        lo, hi = g.span()
        widths.append(hi - lo)
    y = 3 * r + 1 + rng.randint(0, 2)  # above a floor lane (y = r) by 2r + 1 at least
    order = list(range(len(groups)))
    rng.shuffle(order)
    placed = []
    for k in order:
        g = groups[k]
        wall = getattr(g, "wall_lane", None)
        if wall == "floor":
            base = r
        elif wall == "ceiling":
            base = None  # L - r, once L is known
        else:
            base = y
            y = y + max(g.lanes()) + 2 * r + 1 + rng.randint(0, 2)
        placed.append((g, base))
    y += 2 * r  # below a ceiling lane (y = L - r) by 2r + 1 at least
    L = Fraction(max(int(max(widths) + 4 * r) + 1 + 2 * 8, int(y + r) + 1) + rng.randint(0, 8))
    parts, checks = [], []
    for g, _ in placed:
        lo, hi = g.span()
        if g.anchored:  # designed against the left wall: x as given, maybe mirrored to the right
            if rng.random() < 0.5:
                mirror_x(g, L)
        else:
            room = int(L - 2 * r - (hi - lo))
            shift = -lo + r + Fraction(rng.randint(1, max(1, room - 1)))
            for p in g.parts:
                p[0] += shift
    for g, base in placed:
        if base is None:
            base = L - r
        first = len(parts)
        for p in g.parts:
            parts.append([p[0], base + p[1], p[2], p[3]])
        for c in g.checks:
            step, i, kind, j, t = c
            if kind == "tie":
                j = [(first + a, first + b) for a, b in j]
            else:
                i = first + i
                j = None if j is None else first + j
            checks.append((step, i, kind, j, t))
    return L, r, parts, checks


def draw(rng, family):
    """One scene of a family: (L, r, steps, particles, checks), symmetrised and shuffled."""
    if family == "hidden-corners":
        L, r, parts, checks = corners(rng)
    elif family == "hidden-lattice":
        L, r, parts, checks = dense(rng)
    elif family == "hidden-converging":
        L, r, parts, checks = converging(rng)
    else:
        L, r, parts, checks = lanes_scene(rng, family)
        if rng.random() < 0.5:  # lanes along y instead of x
            for p in parts:
                p[0], p[1], p[2], p[3] = p[1], p[0], p[3], p[2]
        if rng.random() < 0.5:  # floor and ceiling swapped
            for p in parts:
                p[1], p[3] = L - p[1], -p[3]
    outside = [p for p in parts if not all(r <= c <= L - r for c in p[:2])]
    if outside:  # the scene format wants every centre inside [r, L - r]: draw again
        raise ValueError(f"a centre outside [r, L - r]: {[float(c) for c in outside[0]]}")
    perm = list(range(len(parts)))
    rng.shuffle(perm)  # perm[old] = new index
    new_parts = [None] * len(parts)
    for old, new in enumerate(perm):
        new_parts[new] = parts[old]
    new_checks = []
    for step, i, kind, j, t in checks:
        if kind == "tie":
            keys = sorted(tuple(sorted((perm[a], perm[b]))) for a, b in j)
            lo, hi = keys[0]
            others = {x for k in keys[1:] for x in k} - {lo, hi}
            new_checks += [(step, lo, "pair", hi, t), (step, hi, "pair", lo, t)]
            new_checks += [(step, o, "nopair", None, None) for o in others]
        else:
            new_checks.append((step, perm[i], kind, None if j is None else perm[j], t))
    # A wall-and-pair tie is decided by the kind of the events alone (a heap ordered by time, or
    # by time and indices, takes the pair) only when the pair's lower index is below the wall's
    # particle: every draw of a family that designs such ties must hold one.
    kinds = [(i, j) for _, i, kind, j, _ in new_checks if kind == "kind"]
    if kinds and not any(j < i for i, j in kinds):
        raise ValueError("no wall-and-pair tie whose pair has the lower index")
    if family == "hidden-ties" and not kinds:
        raise ValueError("no wall-and-pair tie")
    new_checks = [c for c in new_checks if c[2] != "kind"]
    steps = max([c[0] for c in new_checks] + [0]) + rng.randint(10, 24)
    return L, r, steps, new_parts, new_checks


def num(q):
    """A dyadic Fraction written exactly (a finite decimal)."""
    q = Fraction(q)
    assert q.denominator & (q.denominator - 1) == 0, f"{q} is not dyadic"
    if q.denominator == 1:
        return str(q.numerator)
    s = f"{float(q):.20f}".rstrip("0")
    assert Fraction(s) == q
    return s


def scene_text(L, r, steps, parts):
    lines = [str(len(parts)), num(L), num(r), str(steps), "print"]
    lines += [f"{i} {num(p[0])} {num(p[1])} {num(p[2] + 0)} {num(p[3] + 0)}"
              for i, p in enumerate(parts)]
    return "\n".join(lines) + "\n"


def explain(reference, scene, step, ids):
    """{particle: its event in the step} as the reference's greedy oracle sees it, read from its
    JSON (`--explain STEP:i,... --json`): {"event": "free" | "wall" | "pair", "partner", "t"},
    each t the reference's own double."""
    out = subprocess.run([str(reference), str(scene), "--explain",
                          f"{step}:{','.join(map(str, ids))}", "--json"],
                         capture_output=True, text=True, check=True).stdout
    return {e["i"]: e for e in json.loads(out)["particles"]}


def verify(reference, scene, checks):
    """The designed events, as the reference's greedy oracle sees them; a list of mismatches.
    A designed wall or pair event inside a step (0 < t < 1) must be the designed t exactly, not t
    rounded: the kit's C++ computes it (model.hpp, in the reference), never this file."""
    bad, by_step = [], {}
    for c in checks:
        by_step.setdefault(c[0], []).append(c)
    for step, cs in sorted(by_step.items()):
        said = explain(reference, scene, step, sorted({c[1] for c in cs}))
        for _, i, kind, j, t in cs:
            got = said.get(i, {})
            if kind == "nopair":  # lost a tie: free, or its own wall later in the step
                if got.get("event", "pair") == "pair":
                    bad.append(f"step {step} particle {i}: want no pair, reference says {got}")
                continue
            if got.get("event") != kind or (kind == "pair" and got.get("partner") != j):
                bad.append(f"step {step} particle {i}: want {kind}"
                           f"{f' with {j}' if kind == 'pair' else ''}, reference says {got}")
            elif kind in ("wall", "pair") and f"{got['t']:.8f}" != f"{float(t or 0):.8f}":
                bad.append(f"step {step} particle {i}: {kind} at t = {got['t']!r}, designed {t}")
            elif kind in ("wall", "pair") and 0 < t < 1 and got["t"] != float(t):
                bad.append(f"step {step} particle {i}: {kind} at {got['t']!r} in doubles, "
                           f"designed {t} (not exact)")
    return bad


def reference_program(plab):
    try:
        ref = json.loads((KIT / "datasets" / "manifest.json").read_text())["reference_stage"]
    except (OSError, ValueError, KeyError):
        ref = "02"
    return pathlib.Path(plab).parent / f"plab-run-{ref}-solution"


def family_seed(seed, stage, k):
    return (seed * 1000003 + int(stage) * 101 + k) % 2**32


def make_family(seed, stage, k, family, reference, path, plab):
    """Writes one family scene to path, drawn from (seed, stage, k), verified by the reference."""
    problems = []
    for attempt in range(ATTEMPTS):
        rng = random.Random(f"plab-hidden/{family_seed(seed, stage, k)}/{family}/{attempt}")
        try:
            L, r, steps, parts, checks = draw(rng, family)
        except ValueError as e:
            problems = [str(e)]
            continue
        path.write_text(scene_text(L, r, steps, parts))
        problems = verify(reference, path, checks)
        if family == "hidden-lattice":
            problems += dense_check(reference, path, plab)
        if not problems:
            return path
    raise RuntimeError(f"{family}: no scene with its designed events in {ATTEMPTS} attempts "
                       f"(seed {seed}, stage {stage}): {problems[:3]}")


def dense_check(reference, path, plab):
    """A dense lattice must have both wall and pair events in its first step."""
    ev = path.with_suffix(".events")
    subprocess.run([str(reference), str(path), "--quiet", "--steps", "1", "--out", "/dev/null",
                    "--events", str(ev)], check=True, capture_output=True)
    kinds = {e["kind"] for e in plabio.Plab(plab).read_events(ev)["events"]}
    ev.unlink()
    return [] if {"wall", "pair"} <= kinds else [f"step 0 has events {sorted(kinds)} only"]


def family_names(rubric, stage=None):
    """The hidden families of a stage: its rubric entry's own "hidden_families" when it has one
    (stage 07 leaves out the jammed lattice, see the rubric), else the correctness section's."""
    own = rubric.get("stages", {}).get(str(stage), {}).get("hidden_families")
    return list(own if own is not None else rubric["correctness"].get("hidden_families", []))


def hidden_scenes(seed, stage, rubric, plab, out_dir, only=None):
    """(name, scene file) of every hidden scene of one stage: the rubric's random scenes
    ("hidden_scenes", made by `plab gen --seed`), then one scene per family in
    "hidden_families". `only` keeps one name."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    corr = rubric["correctness"]
    scenes = []
    for k, h in enumerate(corr["hidden_scenes"]):
        if only and h["name"] != only:
            continue
        scene = out_dir / f"{h['name']}.in"
        plabio.Plab(plab).gen(scene, "--n", h["n"], "--l", h["L"], "--r", h["r"], "--steps",
                              h["steps"], "--seed", family_seed(seed, stage, k))
        scenes.append((h["name"], scene))
    clash = set(family_names(rubric)) & {h["name"] for h in corr["hidden_scenes"]}
    if clash:  # one file per name in out_dir, one name per test
        raise ValueError(f"rubric: hidden families and hidden scenes share names {sorted(clash)}")
    reference = reference_program(plab)
    base = len(corr["hidden_scenes"])
    for k, family in enumerate(family_names(rubric, stage)):
        if family not in FAMILIES and family not in TWO_D:
            raise ValueError(f"rubric names an unknown hidden family {family!r}")
        if only and family != only:
            continue
        scenes.append((family, make_family(seed, stage, base + k, family, reference,
                                           out_dir / f"{family}.in", plab)))
    return scenes


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 epilog="Writes the hidden scene(s) of one grading's seed and stage.")
    ap.add_argument("--seed", type=int, required=True, help="the grading's hidden seed")
    ap.add_argument("--stage", required=True, help="stage number, e.g. 01")
    ap.add_argument("--only", help="one scene name (e.g. hidden-ties); default: every one")
    ap.add_argument("--out", help="with --only: write the scene here (default NAME.in)")
    ap.add_argument("--dir", default=".", help="without --only: folder for NAME.in files")
    ap.add_argument("--rubric", default=str(KIT / "kit" / "grade" / "rubric.json"),
                    help="the grading rubric")
    ap.add_argument("--plab", default=str(KIT / "build" / "bin" / "plab"),
                    help="the kit's plab program (its folder holds the reference)")
    a = ap.parse_args()
    if not pathlib.Path(a.plab).is_file():
        sys.exit(f"plab.grade.hidden: {a.plab} is not built yet: run ./plab once in the kit (it "
                 "builds the kit), then this command again")
    rubric = json.loads(pathlib.Path(a.rubric).read_text())
    import tempfile
    import shutil
    with tempfile.TemporaryDirectory() as tmp:
        made = hidden_scenes(a.seed, a.stage, rubric, a.plab, pathlib.Path(tmp), a.only)
        if a.only and not made:
            sys.exit(f"plab.grade.hidden: no hidden scene named {a.only!r}")
        for name, path in made:
            dest = pathlib.Path(a.out) if (a.only and a.out) else pathlib.Path(a.dir) / f"{name}.in"
            shutil.copyfile(path, dest)
            print(dest)


if __name__ == "__main__":
    main()
