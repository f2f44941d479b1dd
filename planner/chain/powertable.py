r"""Battery power of one aircraft at a set of flight states, for many take-off masses.

Part of the mission chain (:mod:`planner.chain.mission_chain`): every pack of a catalog changes the
take-off mass, so the chain asks the aircraft's power model for the same flight states
(legs, return-home points, the hold) at many masses. :class:`PowerTable` de-duplicates
the states and, for large catalogs, interpolates :math:`\ln P` in :math:`\ln m` between
exact model evaluations, checked against the model.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PowerTable", "safe_log"]

#: Masses within this range of ln m (± about 12 %: the payload spread of a Monte Carlo
#: run) are interpolated with :data:`NARROW_NODES` nodes, which the check against the
#: exact model accepts there as it accepts 16 nodes over a catalog. [unitless]
NARROW_LOG_MASS_RANGE = 0.25
NARROW_NODES = 8


class PowerTable:
    r"""
    Battery power of one aircraft at a set of flight states, for any take-off masses.

    The flight states (airspeed, climb rate, air density, load factor) of the legs,
    of the return-home points and of the hold are de-duplicated; the power at a block
    of masses is then ``aircraft.battery_power(state..., mass[:, None])``.

    With many distinct masses (a large catalog) evaluating the model at every
    (mass, state) pair costs too much for the iterative momentum model (a few µs per
    pair). Then (``method="table"``, chosen by ``"auto"`` when the catalog has more
    than ``2 * nodes - 1`` distinct masses, i.e. when it needs fewer model calls) the
    model is evaluated exactly at ``nodes`` Chebyshev masses spanning the catalog and
    :math:`\ln P` is interpolated in :math:`\ln m` (barycentric formula, one matrix
    product for all packs). Every state is checked at the ``nodes - 1`` masses between
    the nodes against the exact model. A state that misses by more than ``tolerance``
    (relative) — a kink such as the idle-speed power floor of a fast descent — is
    interpolated piecewise instead: its mass range is halved until each piece passes
    the same check (at most ``max_depth`` halvings; a piece that still fails, and any
    state whose power is not positive and finite, is evaluated exactly).

    Parameters
    ----------
    aircraft : Aircraft
    airspeed, climb_rate, air_density, load_factor : array_like
        One element per flight state (broadcast together). [m/s], [m/s], [kg m⁻³], [–]
    masses : array_like
        All take-off masses that will be asked for. [kg]
    method : {"auto", "exact", "table"}
    nodes : int, default 16
    tolerance : float, default 1e-9
        Largest relative error accepted at the check masses. [unitless]
    max_depth : int, default 16
    """

    def __init__(self, aircraft, airspeed, climb_rate, air_density, load_factor,
                 masses, *, method: str = "auto", nodes: int = 16, tolerance: float = 1e-9,
                 max_depth: int = 16):
        if method not in ("auto", "exact", "table"):
            raise ValueError(f"method must be 'auto', 'exact' or 'table', got {method!r}")
        cols = np.broadcast_arrays(*(np.asarray(a, float) for a in
                                     (airspeed, climb_rate, air_density, load_factor)))
        states = np.column_stack([np.ravel(c) for c in cols])
        if np.all(np.isfinite(states)):
            self.states, self.inverse = np.unique(states, axis=0, return_inverse=True)
            self.inverse = self.inverse.ravel()
        else:  # np.unique does not merge NaN rows reliably: keep every state
            self.states, self.inverse = states, np.arange(len(states))
        self.aircraft = aircraft
        m = np.unique(np.asarray(masses, float))
        if m.size > 1 and np.log(m[-1] / m[0]) < NARROW_LOG_MASS_RANGE:
            nodes = min(nodes, NARROW_NODES)   # the check below still holds the tolerance
        if method == "auto":
            method = "table" if m.size > 2 * nodes - 1 else "exact"
        self.method = method
        self.n_table = 0
        self.pieces: list[list[tuple]] = []
        self.model_calls = 0
        if method == "table" and m.size > 1 and m[-1] > m[0]:
            self._build_table(np.log(m[0]), np.log(m[-1]), nodes, tolerance, max_depth)
        else:
            self.method = "exact"

    # -- exact model calls
    def _exact(self, mass, columns):
        s = self.states[columns]
        self.model_calls += len(mass) * len(s)
        return np.asarray(self.aircraft.battery_power(
            s[:, 0], s[:, 1], s[:, 2], np.asarray(mass, float)[:, None],
            load_factor=s[:, 3]), dtype=float).reshape(len(mass), len(columns))

    def _fit(self, lo, hi, columns, nodes, tolerance):
        """Interpolate ln P of each column on its own interval [lo, hi] (ln mass).

        ``lo``, ``hi`` broadcast against ``columns``; one model call for the nodes and
        one for the check masses of all (column, interval) pairs. Returns the nodes,
        weights, ln P at the nodes (nodes × columns), and which columns have a positive
        finite power and which pass the check.
        """
        columns = np.asarray(columns)
        lo, hi = (np.broadcast_to(np.asarray(v, float), columns.shape) for v in (lo, hi))
        j = np.arange(nodes)[:, None]
        c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
        x = c + h * np.cos(np.pi * j / (nodes - 1))           # Chebyshev points, 2nd kind
        w = (-1.0) ** np.arange(nodes)
        w[[0, -1]] *= 0.5
        x_check = c + h * np.cos(np.pi * (j[:-1] + 0.5) / (nodes - 1))
        st = self.states[columns]

        def call(log_mass):
            self.model_calls += log_mass.size
            return np.asarray(self.aircraft.battery_power(
                st[:, 0], st[:, 1], st[:, 2], np.exp(log_mass), load_factor=st[:, 3]),
                dtype=float) * np.ones(log_mass.shape)

        p_nodes, p_check = call(x), call(x_check)
        positive = np.all(np.isfinite(p_nodes) & (p_nodes > 0), axis=0) & np.all(
            np.isfinite(p_check) & (p_check > 0), axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            y = np.log(np.where(positive, p_nodes, 1.0))
            # barycentric interpolation at the check points, column by column
            d = x_check[:, None, :] - x[None, :, :]
            q = w[None, :, None] / d
            y_check = np.sum(q * y[None], axis=1) / np.sum(q, axis=1)
            err = np.abs(np.expm1(y_check - np.log(np.where(positive, p_check, 1.0))))
        return x, w, y, positive, positive & np.all(err <= tolerance, axis=0)

    def _build_table(self, lo, hi, nodes, tolerance, max_depth):
        all_cols = np.arange(len(self.states))
        x, w, y, positive, good = self._fit(lo, hi, all_cols, nodes, tolerance)
        # the states interpolated over the whole range first (one contiguous block)
        order = np.concatenate([np.flatnonzero(good), np.flatnonzero(~good)])
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        self.states, self.inverse = self.states[order], rank[self.inverse]
        self.n_table = int(good.sum())
        self.nodes_log_mass, self.weights = x[:, 0], w
        self.log_power_nodes = np.ascontiguousarray(y[:, order[:self.n_table]])
        # the others: halve their mass range until each piece passes (breadth first,
        # every piece of one level in one model call)
        rest = np.arange(self.n_table, len(self.states))
        pieces: dict[int, list[tuple]] = {int(c): [] for c in rest}
        pending = [(int(c), lo, hi) for c in rest if positive[order[c]]]
        for c in rest:
            if not positive[order[c]]:
                pieces[int(c)].append((lo, hi, None, None, None))
        for depth in range(max_depth + 1):
            if not pending:
                break
            cols = np.array([p[0] for p in pending])
            los = np.array([p[1] for p in pending])
            his = np.array([p[2] for p in pending])
            x, w, y, positive, good = self._fit(los, his, cols, nodes, tolerance)
            nxt = []
            for i, (c, a, b) in enumerate(pending):
                if good[i]:
                    pieces[c].append((a, b, x[:, i], w, y[:, i]))
                elif not positive[i] or depth == max_depth:
                    pieces[c].append((a, b, None, None, None))   # exact model here
                else:
                    mid = 0.5 * (a + b)
                    nxt += [(c, a, mid), (c, mid, b)]
            pending = nxt
        self.pieces = [sorted(pieces[int(c)], key=lambda p: p[0]) for c in rest]

    def power(self, mass) -> np.ndarray:
        """Battery power at every de-duplicated state, shape (len(mass), n_states). [W]"""
        return np.exp(self.log_power(mass))

    def log_power(self, mass) -> np.ndarray:
        """:math:`\\ln P` at every state, shape (len(mass), n_states); −inf where P ≤ 0."""
        mass = np.asarray(mass, float).ravel()
        if self.method == "exact":
            # one model call per distinct mass (Monte Carlo samples share a few)
            uniq, inv = np.unique(mass, return_inverse=True)
            return safe_log(self._exact(uniq, np.arange(len(self.states))))[inv.ravel()]
        out = np.empty((mass.size, len(self.states)))
        lnm = np.log(mass)
        basis = _barycentric(lnm, self.nodes_log_mass, self.weights)
        np.matmul(basis, self.log_power_nodes, out=out[:, :self.n_table])
        for c, pieces in enumerate(self.pieces, start=self.n_table):
            edges = np.array([p[1] for p in pieces[:-1]])
            which = np.searchsorted(edges, lnm)
            for q in np.unique(which):
                rows = np.flatnonzero(which == q)
                _, _, x, w, y = pieces[q]
                if x is None:
                    out[rows, c] = safe_log(self._exact(mass[rows], [c]))[:, 0]
                else:
                    out[rows, c] = _barycentric(lnm[rows], x, w) @ y
        return out


def safe_log(p):
    """ln P with −inf where P ≤ 0 (a rest) and NaN kept."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(p > 0, np.log(np.where(p > 0, p, 1.0)), np.where(np.isnan(p), np.nan,
                                                                         -np.inf))


def _barycentric(x, nodes, weights):
    """Lagrange basis at ``x`` for the given nodes (barycentric formula), shape (x, nodes)."""
    x = np.asarray(x, float).ravel()
    d = x[:, None] - nodes[None, :]
    hit = d == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        q = weights / d
        basis = q / q.sum(axis=1, keepdims=True)
    rows = hit.any(axis=1)
    if rows.any():
        basis[rows] = hit[rows].astype(float)
    return basis


