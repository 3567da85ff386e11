"""NURBS curves (UsdGeomNurbsCurves) evaluated exactly, as polylines for the delegate's curves,
and NURBS patches (UsdGeomNurbsPatch) as grids of quads (`patch_matrix`).

Each curve of `order` k (degree p = k - 1) has `curveVertexCounts` n control vertices, n + k
`knots` and optional `pointWeights` (rational curves: a circle is exact) and `ranges` (the
parameter interval drawn; unauthored: [knots[p], knots[n]]; a range reaching past that domain
is cut to it and reported). The curve is sampled at every knot inside its range and
SAMPLES_PER_SPAN times across each knot span (once for degree 1, whose spans are straight), by
the Cox-de Boor recursion with the weights folded in. An interior knot repeated `order` times
or more breaks the curve: it is sampled on both sides of the break (each side's limit) and
drawn as separate pieces, a patch without the strip between them. A sample is a
fixed rational combination of the control vertices, so one matrix per curve carries the control
vertices to the polyline; the same matrix carries every time sample of the points, velocities,
accelerations and `vertex` widths or normals, which therefore move and blend with the curve.
"""
import numpy as np

SAMPLES_PER_SPAN = 16


class NurbsError(ValueError):
    """A curve that cannot be evaluated: `attribute` names what is wrong."""

    def __init__(self, attribute, message):
        ValueError.__init__(self, message)
        self.attribute = attribute


def _span(u, p, n, knots):
    """The knot span index s (p <= s < n) with knots[s] <= u < knots[s + 1] (the last non-empty
    span for u at the end of the domain)."""
    if u >= knots[n]:
        s = n - 1
        while s > p and knots[s] >= knots[s + 1]:
            s -= 1
        return s
    lo, hi = p, n
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if u < knots[mid]:
            hi = mid
        else:
            lo = mid
    return lo


def _span_before(u, p, n, knots):
    """The span s (p <= s < n) whose interval (knots[s], knots[s + 1]] holds u: where the curve
    arrives at u from below."""
    s = n - 1
    while s > p and knots[s] >= u:
        s -= 1
    return s


def _basis(s, u, p, knots):
    """The p + 1 B-spline basis functions that are non-zero at u in span s (Cox-de Boor)."""
    n = np.zeros(p + 1)
    left = np.zeros(p + 1)
    right = np.zeros(p + 1)
    n[0] = 1.0
    for j in range(1, p + 1):
        left[j] = u - knots[s + 1 - j]
        right[j] = knots[s + j] - u
        saved = 0.0
        for r in range(j):
            den = right[r + 1] + left[j - r]
            tmp = n[r] / den if den != 0.0 else 0.0
            n[r] = saved + right[r + 1] * tmp
            saved = left[j - r] * tmp
        n[j] = saved
    return n


class Banded:
    """A (rows x count) matrix whose row r holds `order` values from column `start[r]` on: the
    rational basis of a curve, of which only `order` functions are nonzero at a parameter (a
    dense matrix of a 10 000-vertex curve's 160 000 samples would take 12 GB)."""

    def __init__(self, start, values, count):
        self.start, self.values, self.count = start, values, count

    @property
    def shape(self):
        return (len(self.start), self.count)

    def __len__(self):
        return len(self.start)

    def __getitem__(self, rows):
        return Banded(self.start[rows], self.values[rows], self.count)

    def __matmul__(self, data):
        """The product with `data` (count x d)."""
        data = np.asarray(data, dtype=np.float64)
        cols = self.start[:, None] + np.arange(self.values.shape[1])[None, :]
        return np.einsum("rk,rkd->rd", self.values, data[cols])

    def toarray(self):
        m = np.zeros(self.shape)
        for k in range(self.values.shape[1]):
            m[np.arange(len(self.start)), self.start + k] = self.values[:, k]
        return m


def curve_matrix(order, knots, weights, rng, count, per_span=SAMPLES_PER_SPAN, note=None):
    """(samples x count) matrix of the rational basis at the curve's sample parameters (a
    `Banded` one), and the rows r after which the curve breaks (row r is a piece's end, row
    r + 1 the next one's start). `note(attribute, message)` hears of what is repaired (a range
    cut to the domain)."""
    p = int(order) - 1
    if p < 1:
        raise NurbsError("order", "order %d is below 2" % order)
    if count < order:
        raise NurbsError("curveVertexCounts", "%d vertices for order %d" % (count, order))
    knots = np.asarray(knots, dtype=np.float64)
    if knots.size != count + order:
        raise NurbsError("knots", "%d knots for %d vertices of order %d (need %d)"
                         % (knots.size, count, order, count + order))
    if not np.all(np.isfinite(knots)) or np.any(np.diff(knots) < 0):
        raise NurbsError("knots", "the knots are not finite and non-decreasing")
    w = np.ones(count) if weights is None else np.asarray(weights, dtype=np.float64)
    if not (np.all(np.isfinite(w)) and np.all(w > 0)):
        raise NurbsError("pointWeights", "weights must be finite and positive")
    lo, hi = (knots[p], knots[count]) if rng is None else (float(rng[0]), float(rng[1]))
    if rng is not None and np.isfinite(lo) and np.isfinite(hi) and hi > lo and (lo < knots[p] or hi > knots[count]) \
            and note is not None:
        note("ranges", "the range [%g, %g] reaches past the knots' domain [%g, %g]; drawn within "
             "it" % (lo, hi, knots[p], knots[count]))
    lo, hi = max(lo, knots[p]), min(hi, knots[count])
    if not hi > lo:
        raise NurbsError("ranges" if rng is not None else "knots",
                         "the curve's parameter range [%g, %g] is empty" % (lo, hi))
    breaks = np.unique(np.concatenate([[lo, hi], knots[(knots > lo) & (knots < hi)]]))
    # an interior knot of multiplicity > p: the curve jumps there
    jumps = {b for b in breaks[1:-1] if np.count_nonzero(knots == b) > p}
    steps = 1 if p == 1 else per_span
    params = [(breaks[0], False)]
    cuts = []
    for a, b in zip(breaks[:-1], breaks[1:]):
        params.extend((a + (b - a) * (k / steps), k == steps and b in jumps) for k in range(1, steps + 1))
        if b in jumps:
            cuts.append(len(params) - 1)
            params.append((b, False))
    start = np.zeros(len(params), dtype=np.int64)
    values = np.zeros((len(params), p + 1))
    for row, (u, arriving) in enumerate(params):
        s = _span_before(u, p, count, knots) if arriving else _span(u, p, count, knots)
        nw = _basis(s, u, p, knots) * w[s - p:s + 1]
        start[row] = s - p
        values[row] = nw / nw.sum()
    return Banded(start, values, count), cuts


class CurvesMap:
    """The matrices of every curve of a NurbsCurves prim, applied to per-vertex data."""

    def __init__(self, counts, orders, knots, weights, ranges, problem):
        self.blocks = []        # (curve index, first control vertex, count, matrix)
        self.dropped = 0
        first = koff = 0
        for i, (c, k) in enumerate(zip(counts, orders)):
            c, k = int(c), int(k)
            try:
                m, cuts = curve_matrix(k, knots[koff:koff + c + k],
                                       None if weights is None else weights[first:first + c],
                                       None if ranges is None else ranges[i], c,
                                       note=lambda attr, msg: problem(attr, "curve %d: %s" % (i, msg)))
                # each piece of a broken curve is a curve of its own (the same curve's values)
                for a, b in zip([0] + [r + 1 for r in cuts], cuts + [len(m) - 1]):
                    self.blocks.append((i, first, c, m[a:b + 1]))
            except NurbsError as e:
                problem(e.attribute, "curve %d: %s; that curve is dropped" % (i, e))
                self.dropped += 1
            first += c
            koff += c + k

    def counts(self):
        return [m.shape[0] for _, _, _, m in self.blocks]

    def per_vertex(self, data):
        """Per-control-vertex rows (n x d) carried onto the polylines' vertices."""
        data = np.asarray(data, dtype=np.float64)
        data = data.reshape(len(data), -1)
        out = [m @ data[f:f + c] for _, f, c, m in self.blocks]
        return np.concatenate(out) if out else np.zeros((0, data.shape[1]))

    def per_curve(self, values):
        """One value per curve (rows), repeated on each kept curve's polyline vertices."""
        values = np.asarray(values, dtype=np.float64)
        values = values.reshape(len(values), -1)
        out = [np.repeat(values[i:i + 1], m.shape[0], axis=0) for i, _, _, m in self.blocks]
        return np.concatenate(out) if out else np.zeros((0, values.shape[1]))


PATCH_SAMPLES_PER_SPAN = 8


class PatchMap:
    """A NurbsPatch's control data (nv*nu rows, v-major with u fastest as USD lays them out)
    carried onto its grid of sv*su points (`m @ data`): the rational tensor-product basis,
    applied one direction after the other (memory grows with the grid and the control net,
    not with their product)."""

    def __init__(self, mu, mv, w):
        self.mu, self.mv, self.w = mu, mv, w
        self.den = mv @ w @ mu.T

    def __matmul__(self, data):
        nv, nu = self.w.shape
        d = np.asarray(data, dtype=np.float64).reshape(nv, nu, -1) * self.w[..., None]
        along_v = np.tensordot(self.mv, d, axes=(1, 0))              # sv x nu x k
        num = np.einsum("ia,jak->jik", self.mu, along_v)             # sv x su x k
        return (num / self.den[..., None]).reshape(self.den.size, -1)


# The most grid points a patch is drawn with (two triangles each; as subdivision's cap on
# refined faces): a larger control net is sampled fewer times per knot span.
MAX_PATCH_POINTS = 1 << 22


def patch_matrix(u, v, weights, note=None, per_span=PATCH_SAMPLES_PER_SPAN):
    """A NurbsPatch's evaluation: u and v are (order, knots, range, vertex count) of each
    direction; weights (nv x nu) or None. Returns (a PatchMap carrying the control points
    onto the grid, (su, sv), (u cuts, v cuts): the grid columns and rows after which the
    surface breaks). Rational patches divide by the weighted basis sum at each grid point.
    A grid of more than MAX_PATCH_POINTS takes fewer samples per span (noted on the points).
    `note(attribute, message)` hears of what is repaired."""
    mats, cuts = [], []
    for name, (order, knots, rng, count) in (("u", u), ("v", v)):
        attr = lambda a: {"order": name + "Order", "knots": name + "Knots", "ranges": name + "Range",  # noqa: E731
                          "curveVertexCounts": name + "VertexCount"}.get(a, a)
        try:
            m, c = curve_matrix(order, knots, None, rng, count, per_span,
                                note=None if note is None else lambda a, msg: note(attr(a), msg))
        except NurbsError as e:
            raise NurbsError(attr(e.attribute), str(e))
        mats.append(m.toarray())
        cuts.append(c)
    points = mats[0].shape[0] * mats[1].shape[0]
    if points > MAX_PATCH_POINTS and per_span > 1:
        fewer = max(1, int(per_span * (MAX_PATCH_POINTS / points) ** 0.5))
        if note is not None:
            note("points", "a grid of %d points (%d samples per knot span) is more than %d; drawn "
                 "with %d samples per span" % (points, per_span, MAX_PATCH_POINTS, fewer))
        return patch_matrix(u, v, weights, None, fewer)
    mu, mv = mats
    nu, nv = u[3], v[3]
    w = np.ones((nv, nu)) if weights is None else np.asarray(weights, dtype=np.float64).reshape(nv, nu)
    if not (np.all(np.isfinite(w)) and np.all(w > 0)):
        raise NurbsError("pointWeights", "weights must be finite and positive")
    return PatchMap(mu, mv, w), (mu.shape[0], mv.shape[0]), tuple(cuts)
