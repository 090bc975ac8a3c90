"""Inverse solutions at run time: the Newton polish of candidate roots, numeric inverses from a start
grid, conditioning and rank checks, and the admissibility filter (numpy). The closed-form candidates come
from the generated modules; nothing here is machine-specific."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mountid.runtime.eigen import EQUAL_EIGENVALUES, eigen_jacobian

ADMISSIBILITY_RTOL = 1e-11
"""A root is admissible when each given squared frequency is reproduced by its labelled mode to this
relative tolerance. Roots polished by eigen_newton reproduce it to rounding error (~1e-15) whatever the
conditioning, since the residual is measured on the frequencies (a backward error); a root that puts the
given frequency on the other mode of its block misses it by the gap between the modes, and a root that
did not converge within the step limit misses it by more than this."""

NEWTON_RESIDUAL_RTOL = 1e-14
"""eigen_newton leaves an entry alone once its squared frequencies match the given ones to this relative
size (a few tens of eps: the rounding of the forward map). A rule on the step size would not do: near a
double root the steps keep bouncing at kappa * eps however converged the root is."""

DUPLICATE_RTOL = 1e-9
"""Two admissible roots closer than this (relative, in every unknown), or than the earlier one's condition number
times ADMISSIBILITY_RTOL where that is larger, are one solution reached twice."""


RANK_RTOL = 1e-10
"""A root leaves unknowns undetermined when the smallest singular value of d ln(omega) / d ln(unknowns) is
below this (relative condition number above 1e10): the rounding of the forward map alone then moves the
unknowns by 1e-6 relative, and any measured frequency by far more. Exactly rank-deficient points (a coupling
that vanishes, e.g. isolators in the plane of the centre of mass) give 1e-16 or less."""


ModalModel = Callable[..., tuple]
"""A generated module's ``_model(known, unknowns, modes)``: for flat rows of the ``known`` parameters (a tuple of
(N,) arrays) and the ``unknowns`` (N, n_unknowns), the squared frequencies (N, n_modes), and where ``modes`` the
mass-normalised modal matrix (N, 6, n_modes) and dC/d unknowns (N, n_unknowns, 6, 6) (eigen_newton)."""

ClosedForm = Callable[..., tuple]
"""A generated closed form ``roots(*known, *squared_frequencies)``: one array of candidate roots per unknown, each
of shape (n_roots, *batch) (solve_inverse)."""


class InverseRoots(NamedTuple):
    """Every root of an inverse solution, admissible or not, with its conditioning.

    ``parameters`` maps each unknown to an array of shape (n_roots, *batch) [SI units]; ``admissible`` (same
    shape) marks the roots that are positive, finite, put the given frequencies on their labelled modes and
    are determined by them (full rank). ``condition``: the relative condition number of each root,
    1 / sigma_min(d ln omega / d ln unknowns) (relative change of the unknowns per relative change of the
    frequencies; inf where undetermined, NaN where the root failed). ``jacobian``: d omega_given /
    d unknowns [rad/s per SI unit], shape (n_roots, *batch, n_given, n_unknowns). ``rank_deficient``: the
    roots that reproduce the given frequencies but leave unknowns undetermined (never admissible; see
    :meth:`undetermined`). Inadmissible entries hold whatever the algebra gave (possibly NaN).
    """

    parameters: dict[str, NDArray[np.float64]]
    admissible: NDArray[np.bool_]
    condition: NDArray[np.float64]
    jacobian: NDArray[np.float64]
    rank_deficient: NDArray[np.bool_]

    def std(self, frequency_std: ArrayLike) -> dict[str, NDArray[np.float64]]:
        """Standard deviation of each unknown [SI] at each root, from the standard deviations of the given
        frequencies [rad/s] (independent; broadcast against (*batch, n_given)), to first order:
        cov = J^-1 diag(sigma^2) J^-T. Infinite where the root is rank-deficient, NaN where it failed.
        Raises ValueError for a standard deviation that is negative or not finite."""
        sigma = np.broadcast_to(np.asarray(frequency_std, dtype=float), self.jacobian.shape[:-1])
        if not np.all(np.isfinite(sigma) & (sigma >= 0)):
            raise ValueError(f"frequency_std: a standard deviation must be >= 0 and finite, got {frequency_std!r}")
        with np.errstate(all="ignore"):
            finite = np.all(np.isfinite(self.jacobian), axis=(-1, -2)) & ~self.rank_deficient
            safe = np.where(finite[..., None, None], self.jacobian, np.eye(*self.jacobian.shape[-2:]))
            inv = np.linalg.pinv(safe)  # (..., n_unknowns, n_given)
            var = np.einsum("...ik,...k->...i", inv**2, sigma**2)
            out = np.where(finite[..., None], np.sqrt(var), np.where(self.rank_deficient[..., None], np.inf, np.nan))
        return {u: out[..., j] for j, u in enumerate(self.parameters)}

    def most_specific_undetermined(self) -> tuple[str, ...]:
        """Of the rank-deficient roots (scalar batch), the shortest list of undetermined unknowns; empty when
        no root is rank-deficient."""
        names = [self.undetermined(int(i)) for i in np.flatnonzero(self.rank_deficient)]
        return min(names, key=len) if names else ()

    def undetermined(self, index: tuple[int, ...] | int) -> tuple[str, ...]:
        """The unknowns a root leaves undetermined (``index`` into (n_roots, *batch)): those with a component
        in the null space of d ln omega / d ln unknowns; empty for a determined root."""
        if not self.rank_deficient[index]:
            return ()
        jac = self.jacobian[index]
        x = np.array([self.parameters[u][index] for u in self.parameters])
        if not np.all(np.isfinite(jac)):  # a mode shape at a double root of its block: all of them
            return tuple(self.parameters)
        rel = jac * np.abs(x)[None, :]
        rel = rel / np.maximum(np.abs(rel).max(axis=1, keepdims=True), np.finfo(float).tiny)
        _, sv, vt = np.linalg.svd(rel)
        null = [vt[i] for i in range(len(x)) if i >= len(sv) or sv[i] <= RANK_RTOL * sv[0]]
        names = tuple(u for j, u in enumerate(self.parameters) if any(abs(v[j]) > 0.1 for v in null))
        return names or tuple(self.parameters)  # a kink (two modes of a block coincide): all of them


MAX_RELATIVE_STEP = 0.5
"""Largest relative change of an unknown in one Newton step (eigen_newton's trust region)."""

STALL_STEPS = 8
"""eigen_newton gives a row up once this many steps in a row have not brought its largest relative residual
below half the smallest it had before them: a start that ends in a minimum that is no root (the candidate of a
closed form that puts a given frequency on another mode; a Levenberg-Marquardt start that gave up), or a root
whose residual bounces at the rounding of the forward map, just above NEWTON_RESIDUAL_RTOL. Such rows took all
``max_steps`` before and were most of a numeric inverse's time. A start far from its root that no
Levenberg-Marquardt phase brought near (eigen_newton's ``far_starts``) moves by half an unknown a step under the
trust region (MAX_RELATIVE_STEP) and its residual may take a dozen steps to halve (rectangular from its nominal
c_x to one 280 times stiffer: 895 -> 845 in eight steps, then the root); such steps count as progress while each
lowers the residual by more than the one before (a row that zigzags, or slides towards a bound with ever smaller
gains, does not)."""


def eigen_newton(
    model: ModalModel,
    known: tuple[NDArray, ...],
    unknowns: NDArray,
    mode_index: tuple[int, ...],
    given: NDArray,
    max_steps: int = 40,
    far_starts: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Newton steps on lambda_k(theta) = given_k with dlambda_k/dtheta_j = phi_k^T (dC/dtheta_j) phi_k.

    Flat batches: ``known`` holds arrays of shape (N,), ``unknowns`` is (N, n_unknowns), ``given`` the
    given squared frequencies (N, n_given). ``model(known, unknowns, modes)`` returns (squared frequencies
    (N', n_modes), and when ``modes`` the mass-normalised modal matrix (N', 6, n_modes) and dC/dtheta
    (N', n_unknowns, 6, 6)) for the rows it is given. The residuals use the stable forward map, so the
    polished roots are as accurate as the inverse problem allows. A row is done once its residual is at
    rounding level (NEWTON_RESIDUAL_RTOL), or when its step is not finite (admissibility judges it then);
    only rows not yet done are evaluated again, so closed-form roots that are already converged cost one
    forward evaluation. A row is given up once it stalls (STALL_STEPS); with ``far_starts`` (rows that no
    Levenberg-Marquardt phase brought near a root: a closed form's candidates, the nominal start) a step the
    trust region cut short counts as progress while each such step lowers the residual by more than the one
    before. Returns (unknowns, squared frequencies at them).
    """
    idx = list(mode_index)
    x = np.array(unknowns, dtype=float)
    with np.errstate(all="ignore"):
        lam_all = model(known, x, False)[0]

        def misfit(lam: NDArray, rows: NDArray) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
            """Per row: whether it is still to be polished (a given squared frequency off by more than
            NEWTON_RESIDUAL_RTOL, every one finite), and its largest relative residual."""
            f = lam[:, idx] - given[rows]
            size = np.abs(given[rows])
            pending = np.any(np.abs(f) > NEWTON_RESIDUAL_RTOL * size, axis=-1) & np.all(np.isfinite(f), axis=-1)
            return pending, np.max(np.abs(f) / size, axis=-1)

        pending, best = misfit(lam_all, slice(None))  # best: each row's smallest residual so far
        active = np.flatnonzero(pending & np.all(np.isfinite(x), axis=-1))
        stalled = np.zeros(x.shape[0], dtype=int)  # steps since it last fell below half of that
        cut = np.zeros(x.shape[0], dtype=bool)  # whether its last step was cut short by the trust region
        last = best.copy()  # its residual before that step
        drop = np.zeros(x.shape[0])  # how much the step before lowered it
        # each pass evaluates the rows still active at their current point, so every row's lam_all
        # belongs to its final x when the loop ends
        for step_count in range(max_steps + 1):
            if not active.size:
                break
            sub = tuple(k[active] for k in known)
            lam, phi, dc = model(sub, x[active], True)
            lam_all[active] = lam
            pending, r = misfit(lam, active)
            better = r < 0.5 * best[active]
            best[active] = np.where(better, r, best[active])
            # a step the trust region cut short that lowered the residual by more than the step before it did
            # (which lowered it too) is progress, not a stall: the row is on its way to a root it has not yet
            # come near; one that zigzags, or slides towards a bound with ever smaller gains, is not
            fell = last[active] - r
            climbing = far_starts & cut[active] & (drop[active] > 0) & (fell > drop[active])
            drop[active], last[active] = fell, r
            stalled[active] = np.where(better | climbing, 0, stalled[active] + 1)
            go = pending & (stalled[active] < STALL_STEPS)
            if step_count == max_steps or not np.any(go):
                break
            active, lam, phi, dc = active[go], lam[go], phi[go], dc[go]
            g = given[active]
            f = (lam[:, idx] - g) / g
            # least-squares step in relative terms (rows / lambda, columns * |unknown|): the minimum-norm
            # step of the pseudo-inverse also converges where the frequencies leave an unknown undetermined
            scale = np.where(x[active] != 0, np.abs(x[active]), 1.0)
            jac = eigen_jacobian(phi, dc, idx) * scale[:, None, :] / g[:, :, None]
            ok = np.all(np.isfinite(jac), axis=(-1, -2)) & np.any(jac != 0, axis=(-1, -2))
            safe = np.where(ok[:, None, None], jac, np.eye(*jac.shape[-2:]))
            step = (np.linalg.pinv(safe, rcond=1e-13) @ np.where(ok[:, None], f, 0.0)[..., None])[..., 0]
            # trust region: no unknown moves by more than MAX_RELATIVE_STEP of itself in one step (a full
            # step from a distant start overshoots into another basin; a polish takes tiny steps anyway)
            largest = np.max(np.abs(step), axis=-1, keepdims=True)
            step = step * np.minimum(1.0, MAX_RELATIVE_STEP / np.where(largest > 0, largest, 1.0))
            new = x[active] - scale * step
            ok &= np.all(np.isfinite(new), axis=-1)
            cut[active] = largest[:, 0] > MAX_RELATIVE_STEP
            active = active[ok]
            x[active] = new[ok]
    return x, lam_all


LM_STEPS = 80
"""Iterations (accepted or refused steps) allowed to eigen_levenberg_marquardt per start."""

LM_DAMPING = (1e-3, 1e12)
"""Initial damping of eigen_levenberg_marquardt (a kept step divides it by 3, down to 1e-9 of this), and the
damping at which a start is given up (its steps no longer lower the residual: a minimum that is not a root,
or a bound of the floating-point range)."""

LM_STALL = 12
"""eigen_levenberg_marquardt hands a start on to Newton once this many iterations in a row have not brought its
residual norm below half the smallest it had before them (the cost below a quarter). Starts that lead to no root
crept along a valley towards an unknown of 0 or infinity for the rest of LM_STEPS (three quarters of genset8's
starts over x, psi, theta and phi at its nominal frequencies); a start on its way to a root halves its residual
every few iterations, even along the valley of a degenerate layout, and Newton polishes the rest."""

LM_RANGE = 1e4
"""eigen_levenberg_marquardt gives a start up once an unknown has moved by more than this factor from it: it
slides to an unknown of 0 or infinity along a valley that holds no root (the grid's starts spread the ratios
over a decade; a root this far from every start is not promised)."""

LM_LARGEST_STEP = np.log(10.0)
"""Largest change of ln(unknown) in one step of eigen_levenberg_marquardt (a factor 10)."""


def eigen_levenberg_marquardt(
    model: ModalModel,
    known: tuple[NDArray, ...],
    unknowns: NDArray,
    mode_index: tuple[int, ...],
    given: NDArray,
    max_steps: int = LM_STEPS,
) -> NDArray[np.float64]:
    """Levenberg-Marquardt steps in z = ln(unknowns) on r_k = ln(lambda_k(theta) / given_k), batched as
    :func:`eigen_newton` (same arguments and ``model``): the start of a numeric inverse's polish. The unknowns
    stay positive whatever the step, and a step is kept only where it lowers |r|; the damping mu of
    (J^T J + mu diag(J^T J)) dz = -J^T r grows on a refused step and shrinks on a kept one. Near a degenerate
    layout (two isolator groups at almost one distance: the frequencies hold the sum of their stiffnesses far
    better than either) Newton's undamped steps slide along the valley of that sum to an unknown of 0; these
    follow it to the root. Returns the unknowns where each start stopped (not yet polished to rounding level:
    eigen_newton does that)."""
    idx = list(mode_index)
    x = np.array(unknowns, dtype=float)
    n_rows = x.shape[0]
    cost = np.full(n_rows, np.inf)
    jac = np.full((n_rows, len(idx), x.shape[1]), np.nan)
    res = np.full((n_rows, len(idx)), np.nan)

    def evaluate(rows: NDArray, at: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """Residuals, their cost and d r / d z at the points ``at`` of ``rows`` (nan where the model fails)."""
        with np.errstate(all="ignore"):
            lam, phi, dc = model(tuple(k[rows] for k in known), at, True)
            r = np.log(lam[:, idx] / given[rows])
            j = eigen_jacobian(phi, dc, idx) * at[:, None, :] / lam[:, idx, None]
        c = np.sum(r * r, axis=-1)
        bad = ~(np.isfinite(c) & np.all(np.isfinite(j), axis=(-1, -2)))
        return r, np.where(bad, np.inf, c), j

    start = np.flatnonzero(np.all(np.isfinite(x) & (x > 0), axis=-1))
    if start.size:
        res[start], cost[start], jac[start] = evaluate(start, x[start])
    mu = np.full(n_rows, LM_DAMPING[0])
    best = cost.copy()  # each start's smallest cost so far
    stalled = np.zeros(n_rows, dtype=int)  # iterations since it last fell below a quarter of that
    converged = (NEWTON_RESIDUAL_RTOL * len(idx)) ** 2
    active = start[np.isfinite(cost[start]) & (cost[start] > converged)]
    for _ in range(max_steps):
        if not active.size:
            break
        j, r = jac[active], res[active]
        a = np.swapaxes(j, -1, -2) @ j
        diag = np.diagonal(a, axis1=-2, axis2=-1)
        floor = 1e-12 * np.max(diag, axis=-1, keepdims=True)
        damped = a + (mu[active, None] * np.maximum(diag, floor))[..., None] * np.eye(a.shape[-1])
        gradient = np.swapaxes(j, -1, -2) @ r[..., None]
        with np.errstate(all="ignore"):
            try:
                step = -np.linalg.solve(damped, gradient)[..., 0]
            except np.linalg.LinAlgError:  # singular: J^T J singular with the damping at its floor
                step = -(np.linalg.pinv(damped, rcond=1e-13) @ gradient)[..., 0]
        largest = np.max(np.abs(step), axis=-1, keepdims=True)
        step = step * np.minimum(1.0, LM_LARGEST_STEP / np.where(largest > 0, largest, 1.0))
        trial = x[active] * np.exp(step)
        ok = np.all(np.isfinite(trial), axis=-1)
        new_r, new_cost, new_j = evaluate(active, np.where(ok[:, None], trial, x[active]))
        better = ok & (new_cost < cost[active])
        kept = active[better]
        x[kept], res[kept], cost[kept], jac[kept] = trial[better], new_r[better], new_cost[better], new_j[better]
        mu[active] = np.where(better, np.maximum(mu[active] / 3, LM_DAMPING[0] * 1e-9), mu[active] * 4)
        halved = cost[active] < 0.25 * best[active]
        best[active] = np.where(halved, cost[active], best[active])
        stalled[active] = np.where(halved, 0, stalled[active] + 1)
        gone = np.any(np.abs(np.log(x[active] / unknowns[active])) > np.log(LM_RANGE), axis=-1)
        done = (cost[active] <= converged) | (mu[active] > LM_DAMPING[1]) | gone | (stalled[active] >= LM_STALL)
        active = active[~done]
    return x


def solve_inverse(
    roots: ClosedForm,
    model: ModalModel,
    known: tuple[NDArray, ...],
    frequencies: tuple[NDArray, ...],
    mode_index: tuple[int, ...],
    unknowns: tuple[str, ...],
    mode_block: tuple[int, ...],
    special: tuple = (),
    n_roots: int | None = None,
    start: tuple[float, ...] | None = None,
    numeric: bool = False,
) -> InverseRoots:
    """Every root of an inverse problem: closed-form candidates, Newton polish, admissibility, conditioning.

    ``frequencies``: the given natural frequencies omega [rad/s], one array per given mode; an entry that is not
    positive and finite, or whose square is not, is no frequency, and its row has no admissible root (its square
    would be one: a negative omega reproduced by its positive twin). ``roots(*known, *lambda_given)`` is the
    generated closed form in the squared frequencies: a tuple with one array per unknown, shape (n_roots,
    *batch). ``model`` is as in :func:`eigen_newton`. Rows where no candidate is admissible
    (the closed form can be 0/0 at a legitimate point, e.g. sin(alpha) = 0 for upright isolators) take, in
    turn, the candidates of each engine-derived specialised solution in ``special`` ((index of the known
    parameter that is 0 there, its closed form), ...) and then the single start ``start`` (the description's
    nominal unknowns), each polished by Newton at the row's own parameters. ``n_roots``: root slots per row
    (at least the general closed form's). ``numeric`` (numeric inverses, whose candidates are a start grid):
    each start goes first by Levenberg-Marquardt steps in the logarithms of the unknowns
    (eigen_levenberg_marquardt), then by Newton; and where two or more roots are found, the polish starts
    again midway (geometric mean) between every two of them, for up to BETWEEN_ROUNDS rounds while that finds
    more: roots along a curve of solutions lie next to each other, and one between two others has a narrow
    basin that the grid's starts can all miss. Every root found
    gets its Jacobian and relative condition number;
    a root that reproduces the frequencies at a rank-deficient point is marked, never admissible, and so
    is one where a given mode coincides with the other mode of its block (``mode_block``: each mode's
    block): the frequencies are not differentiable there, and such a root is the edge of a continuum of
    solutions of a decoupled block, not a determined one.
    """
    batch = np.broadcast_shapes(*(np.shape(a) for a in (*known, *frequencies)))
    flat = tuple(np.broadcast_to(k, batch).ravel() for k in known)
    omega = np.stack([np.broadcast_to(g, batch).ravel() for g in frequencies], axis=-1)
    # an overflowing square follows the caller's floating-point state: Machine raises there and names the frequency
    with np.errstate(invalid="ignore"):
        lam_given = np.where(np.isfinite(omega) & (omega > 0), omega**2, np.nan)
    n_batch, n_unknowns, n_given = lam_given.shape[0], len(unknowns), len(frequencies)
    valid = np.all(np.isfinite(lam_given), axis=-1)  # an overflowed square is inf
    if not valid.all():  # rows without frequencies are not solved (a numeric polish would take NaN to eigh)
        inner = solve_inverse(
            roots,
            model,
            tuple(f[valid] for f in flat),
            tuple(omega[valid].T),
            mode_index,
            unknowns,
            mode_block,
            special,
            n_roots,
            start,
            numeric,
        )
        return InverseRoots(*(_rows_of(field, valid, batch) for field in inner))
    cand = _candidates(roots, flat, lam_given, n_unknowns)
    slots = max(n_roots or 0, cand.shape[1])
    x = np.full((n_unknowns, slots, n_batch), np.nan)
    x[:, : cand.shape[1]] = cand
    lam = np.full((slots, n_batch, max(mode_index) + 1), np.nan)  # replaced by the polish (empty batches keep it)
    if n_batch:
        x, lam = _polish(model, flat, x, lam_given, mode_index, numeric)
        fallbacks = [
            (lambda rows, r=r: _candidates(r, tuple(k[rows] for k in flat), lam_given[rows], n_unknowns))
            for _, r in special
        ]
        if start is not None:
            fallbacks.append(
                lambda rows: np.broadcast_to(np.array(start, float)[:, None, None], (n_unknowns, 1, rows.size))
            )
        broken = np.any(~np.isfinite(cand), axis=(0, 1))  # a 0/0 in some slot of the closed form
        for more in fallbacks:
            found = admissible(tuple(x), lam, mode_index, tuple(lam_given.T))
            missed = np.flatnonzero(~np.any(found, axis=0) | broken)
            if not missed.size:
                break
            extra = more(missed)
            sub = tuple(f[missed] for f in flat)
            xs, lams = _polish(model, sub, extra, lam_given[missed], mode_index, numeric)
            for r, row in enumerate(missed):  # into the slots that hold no solution yet (rare rows)
                free = np.flatnonzero(~found[:, row])[: xs.shape[1]]
                x[:, free, row], lam[free, row] = xs[:, : free.size, r], lams[: free.size, r]
        if numeric:
            x, lam = _between_roots(model, flat, x, lam, lam_given, mode_index)
    reproduced = admissible(tuple(x), lam, mode_index, tuple(lam_given.T))
    jac, cond = _conditioning(model, flat, x, mode_index, mode_block, n_given)
    with np.errstate(invalid="ignore"):
        deficient = reproduced & (cond * RANK_RTOL >= 1)
        ok = reproduced & (cond * RANK_RTOL < 1)
        # a root is determined to about its condition number times the admissibility tolerance: roots nearer an
        # earlier one than that are the same solution reached from two starts (DUPLICATE_RTOL alone listed an
        # ill-conditioned one 75 times, its copies 1e-8 apart at a condition number of 1e5)
        spread = np.where(ok, np.maximum(DUPLICATE_RTOL, cond * ADMISSIBILITY_RTOL), DUPLICATE_RTOL)
    _drop_repeats(np.moveaxis(x, 0, -1), ok, spread)
    params = {u: x[j].reshape(slots, *batch) for j, u in enumerate(unknowns)}
    return InverseRoots(
        params,
        ok.reshape(slots, *batch),
        cond.reshape(slots, *batch),
        jac.reshape(slots, *batch, n_given, n_unknowns),
        deficient.reshape(slots, *batch),
    )


def _rows_of(field: dict | NDArray, valid: NDArray[np.bool_], batch: tuple[int, ...]) -> dict | NDArray:
    """A field of InverseRoots solved for the ``valid`` rows of a flattened batch, spread over the whole batch:
    the other rows NaN (False in masks)."""
    if isinstance(field, dict):
        return {u: _rows_of(v, valid, batch) for u, v in field.items()}
    out = np.full((field.shape[0], valid.size, *field.shape[2:]), False if field.dtype == bool else np.nan)
    out[:, valid] = field
    return out.reshape(field.shape[0], *batch, *field.shape[2:])


BETWEEN_ROUNDS = 3
"""Rounds of starts between the roots found (solve_inverse's ``numeric``)."""


def _between_roots(
    model: ModalModel,
    flat: tuple[NDArray, ...],
    x: NDArray,
    lam: NDArray,
    lam_given: NDArray,
    mode_index: tuple[int, ...],
) -> tuple[NDArray, NDArray]:
    """solve_inverse's ``numeric``: polish starts midway between every two admissible roots of a row and put
    the new roots into slots that hold none (x (n_unknowns, slots, B), lam (slots, B, n_modes))."""
    n_unknowns = x.shape[0]
    for _ in range(BETWEEN_ROUNDS):
        found = admissible(tuple(x), lam, mode_index, tuple(lam_given.T))
        rows = np.flatnonzero(found.sum(axis=0) >= 2)
        if not rows.size:
            break
        pairs = []  # per row, the midpoints of its admissible roots two by two (nan where a row has fewer)
        for row in rows:
            roots = x[:, found[:, row], row]
            pairs.append(
                [np.sqrt(roots[:, i] * roots[:, j]) for i, j in itertools.combinations(range(roots.shape[1]), 2)]
            )
        width = max(len(p) for p in pairs)
        starts = np.full((n_unknowns, width, rows.size), np.nan)
        for r, mids in enumerate(pairs):
            starts[:, : len(mids), r] = np.array(mids).T
        xs, lams = _polish(model, tuple(f[rows] for f in flat), starts, lam_given[rows], mode_index, True)
        new = 0
        for r, row in enumerate(rows):
            free = np.flatnonzero(~found[:, row])
            for k in range(width):
                if not free.size:
                    break
                kept = x[:, free[0], row].copy(), lam[free[0], row].copy()
                x[:, free[0], row], lam[free[0], row] = xs[:, k, r], lams[k, r]
                ok = admissible(tuple(x[:, :, row]), lam[:, row], mode_index, tuple(lam_given[row]))
                if ok[free[0]]:  # a root not found before: keep it in that slot
                    new += 1
                    free = free[1:]
                else:  # one found already (or none): the slot keeps what it held
                    x[:, free[0], row], lam[free[0], row] = kept
        if not new:
            break
    return x, lam


def start_grid(
    start: tuple[float, ...], factors: tuple[float, ...], model: ModalModel, mode_index: tuple[int, ...]
) -> ClosedForm:
    """A 'closed form' for a numeric inverse: candidate roots for solve_inverse to polish, each unknown of
    shape (len(factors)**n, B) for flat rows.

    The unknowns are stiffnesses and M does not depend on them, so every squared frequency is homogeneous of
    degree 1 in them: the nominal ``start`` is first scaled, per row, by the geometric mean of given /
    predicted squared frequencies (which fixes the overall level exactly), then multiplied by every
    combination of ``factors`` (which spreads the ratios between the unknowns)."""
    grid = np.array(list(itertools.product(factors, repeat=len(start)))) * np.array(start)  # (n_roots, n)

    def roots(*args: NDArray) -> tuple[NDArray, ...]:
        known, lam = args[: -len(mode_index)], np.stack(args[-len(mode_index) :], axis=-1)
        rows = lam.shape[0]
        with np.errstate(all="ignore"):
            at_start = model(known, np.broadcast_to(np.array(start, float), (rows, len(start))), False)[0]
            level = np.exp(np.mean(np.log(lam / at_start[:, list(mode_index)]), axis=-1))  # (B,)
        return tuple(grid[:, j, None] * level[None, :] for j in range(len(start)))

    return roots


def _candidates(
    roots: ClosedForm, known: tuple[NDArray, ...], lam_given: NDArray, n_unknowns: int
) -> NDArray[np.float64]:
    """A closed form's candidate roots at flat rows, shape (n_unknowns, n_roots, B)."""
    with np.errstate(all="ignore"):
        cand = np.stack(np.broadcast_arrays(*roots(*known, *lam_given.T)))
    if cand.ndim == 3 and cand.shape[2] == lam_given.shape[0]:
        return cand
    return cand.reshape(n_unknowns, -1, lam_given.shape[0])


def _polish(
    model: ModalModel,
    known: tuple[NDArray, ...],
    cand: NDArray,
    lam_given: NDArray,
    mode_index: tuple[int, ...],
    damped: bool = False,
) -> tuple[NDArray, NDArray]:
    """Candidates (n_unknowns, n_roots, B) polished by Newton at the flat rows ``known`` ((B,) each), after
    Levenberg-Marquardt steps (eigen_levenberg_marquardt) where ``damped``. Returns (unknowns
    (n_unknowns, n_roots, B), squared frequencies (n_roots, B, n_modes))."""
    n_unknowns, n_roots, n_batch = cand.shape
    rows = tuple(np.tile(k, n_roots) for k in known)
    given = np.tile(lam_given, (n_roots, 1))
    x0 = cand.reshape(n_unknowns, -1).T
    if damped:
        x0 = eigen_levenberg_marquardt(model, rows, x0, mode_index, given)
    x, lam = eigen_newton(model, rows, x0, mode_index, given, far_starts=not damped)
    return x.T.reshape(n_unknowns, n_roots, n_batch), lam.reshape(n_roots, n_batch, -1)


def _conditioning(
    model: ModalModel,
    known: tuple[NDArray, ...],
    x: NDArray,
    mode_index: tuple[int, ...],
    mode_block: tuple[int, ...],
    n_given: int,
) -> tuple[NDArray, NDArray]:
    """d omega_given / d unknowns (n_roots, B, n_given, n_unknowns) and the relative condition number
    1 / sigma_min(d ln omega / d ln unknowns) (n_roots, B) at every finite root (NaN elsewhere; inf at a
    rank-deficient root and where a given mode coincides with another mode of its block)."""
    n_unknowns, n_roots, n_batch = x.shape
    jac = np.full((n_roots * n_batch, n_given, n_unknowns), np.nan)
    cond = np.full(n_roots * n_batch, np.nan)
    flat = x.reshape(n_unknowns, -1).T
    good = np.flatnonzero(np.all(np.isfinite(flat) & (flat > 0), axis=-1))
    if good.size:
        rows = tuple(np.tile(k, n_roots)[good] for k in known)
        with np.errstate(all="ignore"):
            lam, phi, dc = model(rows, flat[good], True)
            omega = np.sqrt(lam[:, list(mode_index)])
            d_omega = eigen_jacobian(phi, dc, mode_index) / (2.0 * omega[:, :, None])
            rel = d_omega * flat[good][:, None, :] / omega[:, :, None]
            ok = np.all(np.isfinite(rel), axis=(-1, -2))
            sv = np.full((good.size, min(n_given, n_unknowns)), np.nan)
            sv[ok] = np.linalg.svd(rel[ok], compute_uv=False)
            smallest = sv[:, -1]
            for k in mode_index:
                for j, b in enumerate(mode_block):
                    if j != k and b == mode_block[k]:
                        equal = np.abs(lam[:, j] - lam[:, k]) <= EQUAL_EIGENVALUES * lam[:, k]
                        smallest = np.where(equal, 0.0, smallest)
            cond[good] = np.where(smallest > 0, 1.0 / smallest, np.inf)
        jac[good] = d_omega
    return jac.reshape(n_roots, n_batch, n_given, n_unknowns), cond.reshape(n_roots, n_batch)


def admissible(
    unknowns: tuple[NDArray, ...],
    predicted: NDArray,
    mode_index: tuple[int, ...],
    given: tuple[NDArray, ...],
    rtol: float = ADMISSIBILITY_RTOL,
) -> NDArray[np.bool_]:
    """Admissible inverse roots: unknowns positive and finite, given frequencies on their labelled modes.

    ``predicted`` holds the squared frequencies the forward map gives for each root, shape (n_roots, ..., n).
    Each solution is reported once: a root equal to an earlier admissible one is not admissible.
    """
    ok = np.ones(np.broadcast_shapes(*(u.shape for u in unknowns)), dtype=bool)
    for u in unknowns:
        ok &= np.isfinite(u) & (u > 0)
    with np.errstate(invalid="ignore"):
        for k, lam in zip(mode_index, given, strict=True):
            ok &= np.abs(predicted[..., k] - lam) <= rtol * np.abs(lam)
        # a root that repeats an earlier admissible one (two candidates polished onto one solution) is dropped
        _drop_repeats(np.stack(np.broadcast_arrays(*unknowns), axis=-1), ok)
    return ok


def _drop_repeats(x: NDArray, ok: NDArray[np.bool_], rtol: NDArray | float = DUPLICATE_RTOL) -> None:
    """Clear ``ok`` (n_roots, ...) of each root within ``rtol`` of an earlier admissible one in its row (relative
    to the earlier root, with the earlier root's tolerance where ``rtol`` is given per root, shape (n_roots, ...);
    ``x``: (n_roots, ..., n_unknowns)). In rounds: in every row the first root not
    yet decided is kept, and every later one equal to it dropped; a root is dropped exactly when an earlier kept
    root equals it, as comparing each root with every earlier one in turn would find, in as many rounds as a row
    keeps roots (a numeric inverse's grid polishes hundreds of starts onto a handful of roots)."""
    n_roots = x.shape[0]
    if not n_roots:
        return
    flat_x = x.reshape(n_roots, -1, x.shape[-1])
    flat_ok = ok.reshape(n_roots, -1)
    flat_rtol = np.broadcast_to(np.asarray(rtol, dtype=float), ok.shape).reshape(n_roots, -1)
    open_ = flat_ok.copy()
    order = np.arange(n_roots)[:, None]
    while open_.any():
        cols = np.flatnonzero(open_.any(axis=0))
        first = np.argmax(open_[:, cols], axis=0)
        kept = flat_x[first, cols]  # (n_cols, n_unknowns)
        tolerance = flat_rtol[first, cols][None, :, None]
        same = np.all(np.abs(flat_x[:, cols] - kept[None]) <= tolerance * np.abs(kept[None]), axis=-1)
        drop = same & (order > first[None, :]) & open_[:, cols]
        flat_ok[:, cols] &= ~drop
        open_[:, cols] &= ~drop
        open_[first, cols] = False
    ok[...] = flat_ok.reshape(ok.shape)  # (reshape may have copied)
