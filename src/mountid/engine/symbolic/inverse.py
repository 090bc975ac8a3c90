"""Measured frequencies back to unknown stiffnesses: which sets determine them, and how to solve them.

For every set of distinct natural frequencies as large as the number of unknowns:

1. Equations. The frequencies of one block are roots of its characteristic polynomial p(lambda). When all
   roots of a block are given, the equations are Vieta's relations (sums and products of the roots against
   the coefficients of p); otherwise p(lambda_k) = 0 for each given root. Both are polynomial in the unknowns.
2. Identifiability. The rank of the Jacobian of the equations with respect to the unknowns at a generic point
   (random rationals, exact arithmetic, roots to 30 digits): full rank means the set determines the unknowns
   locally; a rank deficit is reported with the reason, never skipped silently. A block too large for a
   symbolic characteristic polynomial (a machine without a plane of symmetry is one 6 x 6 block) has no
   equations: its rank comes from d lambda / d u = phi^T (dC/du) phi of its modes at the same point, and an
   identifiable set is solved numerically (step 3 skipped).
3. Solution. Directed elimination triangularises the system (see InverseDerivation._solve): unknowns that
   occur linearly are solved for and substituted, in the form with the fewest subtractions, leaving one
   polynomial in the last unknown, factored over the parameters. (A lexicographic Groebner basis does the
   same on small systems but takes minutes once a dozen parameters and trigonometric terms enter.) Roots of
   the univariate factors are taken numerically stably at run time (degree <= 2 in closed form, else
   companion-matrix eigenvalues).

Roots are then filtered at run time (admissibility): every unknown positive and finite, and every given
frequency reproduced by the mode it is labelled as.

4. Special points. A legitimate design can sit where the general solution breaks: isolators in the plane of
   the centre of mass (a height = 0) or upright (an inclination = 0). For every identifiable set and every
   such point (each known height of an isolator point and each inclination angle set to 0) the engine asks
   again: if the set determines the unknowns there (at the generic point) but the general solution divides
   by zero there (a leading coefficient or a back-substitution denominator vanishes identically), the set is
   solved again with the point substituted and the specialised solution is generated beside the general
   one. Whether a set determines the unknowns at a special point can depend on which root of a block is
   the lower one, so the run time checks the rank at every root it finds (mountid.runtime.solve_inverse)
   and names what is left undetermined.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import random
from dataclasses import dataclass

import sympy as sp

from mountid.engine.symbolic.blocks import LAMBDA, ModalStructure
from mountid.engine.symbolic.factoring import factor, factor_list
from mountid.engine.symbolic.model import rational_point
from mountid.errors import DescriptionError
from mountid.nomenclature import counted

POINT_TRIES = 100
"""Generic points tried for one where the mass matrix is positive definite (InverseDerivation._massive_point)."""


@dataclass(frozen=True)
class InverseSet:
    """One set of given frequencies and, if it determines the unknowns, how to solve it."""

    labels: tuple[str, ...]
    identifiable: bool
    reason: str
    """Why the set is not identifiable, or an empty string."""
    lambdas: tuple[sp.Symbol, ...] = ()
    equations: tuple[sp.Expr, ...] = ()
    last: str = ""
    """The unknown solved from the univariate polynomial."""
    factors: tuple[sp.Poly, ...] = ()
    """Univariate factors (in ``last``) whose roots are the candidates; coefficients in knowns and lambdas."""
    back_substitution: tuple[tuple[str, sp.Expr], ...] = ()
    """(unknown, expression in knowns, lambdas and later unknowns), in the order to evaluate."""
    special: tuple[tuple[str, InverseSet], ...] = ()
    """(known parameter set to 0, the solution specialised there) where the general solution is 0/0."""
    numeric: bool = False
    """The set determines the unknowns (full rank) but has no closed form of manageable size (``reason``
    says why): it is solved numerically at run time, by Newton from a grid of starts."""
    undetermined: tuple[str, ...] = ()
    """The unknowns the set leaves undetermined where it fixes fewer combinations of them than there are (those
    with a component in the null space of its Jacobian at the generic point); empty for a set of full rank."""

    @property
    def name(self) -> str:
        return "_".join(self.labels)

    @property
    def n_roots(self) -> int:
        return sum(f.degree() for f in self.factors)


def _cancellation_score(expr: sp.Expr) -> tuple[int, int, int]:
    """Prefer back-substitutions that cannot divide by zero and have no subtraction: first the number of
    denominator factors not provably positive (sin(alpha) vanishes at alpha = 0), then the negative terms
    in numerator and denominator (all physical symbols are positive), then the operation count."""
    num, den = sp.fraction(expr)  # expr comes factored from _eliminate
    risky = sum(1 for f in sp.Mul.make_args(den) if not f.is_positive)
    negatives = 0
    for part in (num, den):
        for piece in sp.Mul.make_args(part):
            terms = sp.Add.make_args(sp.expand(piece))
            if len(terms) > 1:
                negatives += sum(1 for t in terms if t.could_extract_minus_sign())
    return risky, negatives, sp.count_ops(expr)


def _factors_in(poly: sp.Poly) -> list[sp.Poly]:
    """The factors of ``poly`` that depend on its variable, without the root 0 and without the content.

    The content (the gcd of the coefficients, a polynomial in the parameters, e.g. sin(alpha)) would make
    the generated root 0/0 where it vanishes; it is divided out. A primitive part of degree 1 is its own
    factor (factoring a long linear polynomial over the parameters costs seconds and returns it unchanged);
    higher degrees are factored over the parameters, except a quadratic whose discriminant is not a square
    at a rational point: it cannot be a square polynomial, so the primitive quadratic is irreducible (Gauss's
    lemma) and the costly multivariate factoring is skipped.
    """
    x = poly.gen
    low = min(m[0] for m in poly.monoms())
    if low:
        poly = sp.Poly(sp.cancel(poly.as_expr() / x**low), x)
    _, prim = poly.primitive()
    if prim.LC().could_extract_minus_sign():  # the sign factor_list would choose
        prim = -prim
    if prim.degree() <= 1:
        return [prim] if prim.degree() == 1 else []
    if prim.degree() == 2 and _irreducible_quadratic(prim):
        return [prim]
    _, flist = factor_list(prim.as_expr(), x)
    return [sp.Poly(f, x) for f, _mult in flist if sp.Poly(f, x).degree() > 0 and f != x]


def _irreducible_quadratic(poly: sp.Poly) -> bool:
    """Whether a primitive quadratic is certainly irreducible over the parameters: its discriminant is not a
    rational square at a fixed pseudo-random rational point (a square polynomial would be one everywhere)."""
    rng = random.Random(7)
    symbols = sorted(set().union(*(c.free_symbols for c in poly.all_coeffs())), key=str)
    point = {s: sp.Rational(rng.randint(101, 997), rng.randint(101, 997)) for s in symbols}
    a, b, c = (sp.Rational(coef.xreplace(point)) for coef in poly.all_coeffs())
    disc = b * b - 4 * a * c
    if disc < 0:
        return True
    p, q = sp.fraction(disc)
    return not (sp.sqrt(p).is_Integer and sp.sqrt(q).is_Integer)


def _terms(expr: sp.Expr) -> int:
    return len(sp.Add.make_args(expr))


def lambda_symbol(label: str) -> sp.Symbol:
    """Symbol of a squared natural frequency omega_label^2 [rad^2/s^2]."""
    return sp.Symbol(f"lambda_{label}", positive=True)


class InverseDerivation:
    """Enumerate and solve every inverse set of a modal structure."""

    def __init__(self, structure: ModalStructure, seed: int = 20261122) -> None:
        self.structure = structure
        self.settings = structure.settings
        self.model = structure.model
        self.unknowns = tuple(self.model.symbols[n] for n in self.model.description.unknown)
        self._seed = seed
        self._point = self._generic_point(seed)
        self._linear: dict[tuple[sp.Expr, sp.Symbol], tuple | None] = {}
        self._slopes: dict[int, list[list]] = {}

    def _generic_point(self, seed: int) -> dict[sp.Symbol, sp.Rational]:
        return rational_point(self.model.symbols.values(), seed)

    def equations(self, labels: tuple[str, ...]) -> tuple[list[sp.Expr], list[sp.Symbol]] | None:
        """Polynomial equations tying the given squared frequencies to the unknowns (None: too large)."""
        groups: dict[int, list[str]] = {}
        for label in labels:
            twin = self.structure.twin[self.structure.mode(label).block]
            groups.setdefault(twin, []).append(label)
        eqs, lams = [], []
        for k, group in groups.items():
            poly = self.structure.blocks[k].charpoly
            if poly is None:
                return None
            coeffs = poly.all_coeffs()  # highest degree first
            ls = [lambda_symbol(lab) for lab in group]
            lams += ls
            if len(group) == poly.degree():
                for j in range(1, len(ls) + 1):
                    e_j = sum(sp.Mul(*c) for c in itertools.combinations(ls, j))
                    eqs.append(sp.expand(coeffs[0] * e_j - (-1) ** j * coeffs[j]))
            else:
                eqs += [sp.expand(poly.as_expr().subs(LAMBDA, lam)) for lam in ls]
        return eqs, lams

    def _rank(
        self, eqs: list[sp.Expr], labels: tuple[str, ...], special: dict | None = None
    ) -> tuple[int, tuple[str, ...]]:
        """Rank of d(equations)/d(unknowns) at the generic point (with ``special`` substituted), lambdas at
        their true values there, and the unknowns that a rank deficit leaves undetermined (those with a
        component in the null space)."""
        point = {**self._point, **(special or {})}
        subs = dict(point)
        for label in labels:
            mode = self.structure.mode(label)
            block = self.structure.blocks[mode.block]
            p = sp.Poly(block.charpoly.as_expr().subs(point), LAMBDA)
            roots = sorted(sp.re(r) for r in p.nroots(n=40))
            subs[lambda_symbol(label)] = roots[mode.rank - 1]
        jac = sp.Matrix([[sp.diff(e, u) for u in self.unknowns] for e in eqs]).subs(subs).evalf(40)
        return self._rank_of(jac.tolist())

    @functools.cached_property
    def _massive_point(self) -> dict[sp.Symbol, sp.Rational]:
        """The generic point, or the first after it (seeds on from the engine's) where M is positive definite:
        products of inertia drawn as large as the moments of inertia can make the generic point's inertia
        tensor indefinite, where the modes of _eigen_rank do not exist."""
        import mpmath

        for seed in range(self._seed, self._seed + POINT_TRIES):
            point = self._generic_point(seed)
            try:
                with mpmath.workdps(40):
                    mpmath.cholesky(mpmath.matrix(self.model.M.subs(point).evalf(40).tolist()))
            except ValueError:
                continue
            return point
        raise DescriptionError(
            "body", f"the mass matrix is not positive definite at {POINT_TRIES} points with every parameter in [0.5, 2]"
        )

    def _eigen_rank(self, labels: tuple[str, ...]) -> tuple[int, tuple[str, ...]]:
        """As _rank, for sets in a block too large for a symbolic characteristic polynomial: the Jacobian of the
        given squared frequencies (_block_slopes), its rank against the largest derivative of any mode of the
        blocks involved (a mode the mount leaves without stiffness has a zero row, within rounding of that)."""
        rows, scale = [], 0
        for label in labels:
            mode = self.structure.mode(label)
            every = self._block_slopes(mode.block)
            scale = max(scale, *(abs(v) for row in every for v in row))
            rows.append(every[mode.rank - 1])
        return self._rank_of(rows, scale)

    def _block_slopes(self, index: int) -> list[list]:
        """d lambda_r / du = phi_r^T (dC/du) phi_r for every mode r of block ``index`` in ascending order (rows)
        and unknown u (columns), phi_r mass-normalised, at a generic point where M is positive definite
        (_massive_point), to 40 digits; the unknowns are stiffnesses, M does not depend on them. Once per block:
        substituting the point into a 6 x 6 block's symbolic entries is most of the cost."""
        import mpmath

        if index in self._slopes:
            return self._slopes[index]
        point = self._massive_point
        block = self.structure.blocks[index]
        with mpmath.workdps(40):
            mass = mpmath.matrix(block.M.subs(point).evalf(40).tolist())
            stiffness = mpmath.matrix(block.C.subs(point).evalf(40).tolist())
            inverse = mpmath.cholesky(mass) ** -1
            values, vectors = mpmath.eigsy(inverse * stiffness * inverse.T)
            order = sorted(range(block.size), key=lambda i: values[i])
            phis = [inverse.T * vectors[:, i] for i in order]
            slopes = [mpmath.matrix(block.C.diff(u).subs(point).evalf(40).tolist()) for u in self.unknowns]
            self._slopes[index] = [[(phi.T * slope * phi)[0] for slope in slopes] for phi in phis]
        return self._slopes[index]

    def _rank_of(self, jac: list[list], scale: object = 0) -> tuple[int, tuple[str, ...]]:
        """Rank of a Jacobian (rows: equations, columns: the unknowns) to 40 digits, singular values below
        1e-25 of the largest (or of ``scale``, if larger) counted as zero, and the unknowns with a component in
        its null space."""
        import mpmath

        with mpmath.workdps(40):
            _, sv, vt = mpmath.svd_r(mpmath.matrix(jac))
            svs = [abs(sv[i]) for i in range(len(sv))]
            tol = max(*svs, scale) * mpmath.mpf(10) ** -25
            rank = sum(1 for v in svs if v > tol)
            free = set()
            n = len(self.unknowns)
            for i in range(n):  # rows of V^T beyond the rank (and for zero singular values) span the null space
                if i >= len(svs) or svs[i] <= tol:
                    free |= {j for j in range(n) if abs(vt[i, j]) > mpmath.mpf(10) ** -20}
        names = tuple(str(u) for j, u in enumerate(self.unknowns) if j in free)
        return rank, names

    @functools.cached_property
    def special_points(self) -> tuple[str, ...]:
        """Known parameters whose value 0 is a legitimate design that the general solution may not cover:
        the heights of isolator points (isolators in the plane of the centre of mass) and the inclination
        angles (upright isolators)."""
        d = self.model.description
        texts = [g.point[2] for g in d.isolators] + [a for g in d.isolators for a in (g.inclination or ())]
        free: set[sp.Symbol] = set()
        for k, text in enumerate(texts):
            free |= self.model.expr(text, f"isolators[{k}]").free_symbols
        return tuple(
            n for n in d.known if self.model.symbols[n] in free and d.parameters[n].kind in ("length", "angle")
        )

    def _vanishes(self, expr: sp.Expr, special: dict) -> bool:
        """Whether ``expr`` (in parameters and lambdas) is identically zero once ``special`` is substituted:
        exact evaluation at a pseudo-random rational point (a non-zero polynomial vanishes there by chance
        with probability zero)."""
        e = expr.subs(special)
        return sp.simplify(e.subs(rational_point(sorted(e.free_symbols, key=str), 11))) == 0

    def _breaks_at(self, result: InverseSet, special: dict) -> bool:
        """Whether the general solution divides by zero at ``special``."""
        exprs = [f.LC() for f in result.factors] + [sp.fraction(sp.together(e))[1] for _, e in result.back_substitution]
        return any(self._vanishes(e, special) for e in exprs)

    def derive(self, labels: tuple[str, ...], at: dict | None = None, special_points: bool = True) -> InverseSet:
        """The inverse solution of one set of labels; ``at``: known parameters substituted (a special point);
        ``special_points``: also examine the special points (see the module docstring)."""
        got = self.equations(labels)
        if got is None:
            # a block beyond max_symbolic_block (a machine without a plane of symmetry is one 6 x 6 block):
            # the rank from its numeric modes, the solution numeric on the forward map as for a 3x3 block
            rank, free = self._eigen_rank(labels)
            if rank < len(self.unknowns):
                return self._undetermined(labels, rank, free)
            size = max(self.structure.blocks[self.structure.mode(lab).block].size for lab in labels)
            return InverseSet(
                labels,
                True,
                f"a {size}x{size} block, no symbolic characteristic polynomial (solved numerically)",
                tuple(lambda_symbol(lab) for lab in labels),
                numeric=True,
            )
        eqs, lams = got
        if at:
            eqs = [sp.expand(e.subs(at)) for e in eqs]
        rank, free = self._rank(eqs, labels, at)
        if rank < len(self.unknowns):
            return self._undetermined(labels, rank, free)
        if any(self.structure.blocks[self.structure.mode(lab).block].size > 2 for lab in labels):
            # the roots of a cubic block come out of a companion matrix either way: Newton on the forward
            # map is as good, and eliminating through cubic characteristic polynomials costs seconds per set
            return InverseSet(
                labels, True, "a 3x3 block, no closed form generated (solved numerically)", tuple(lams), numeric=True
            )
        # Transcendental known quantities (sin(alpha), ...) become plain symbols for the algebra:
        # elimination and factoring over a coefficient field with trigonometric functions are very slow.
        atoms = sorted(
            {a for e in eqs for a in e.atoms(sp.Function) if not (a.free_symbols & set(self.unknowns))},
            key=sp.default_sort_key,
        )
        hide = {a: sp.Symbol(f"_atom{i}", real=True) for i, a in enumerate(atoms)}
        reveal = {v: k for k, v in hide.items()}
        eqs_algebraic = [e.subs(hide) for e in eqs]
        result = self._solve(labels, eqs_algebraic, lams)
        if not result.identifiable or result.numeric:
            return result
        general = InverseSet(
            labels,
            True,
            "",
            result.lambdas,
            tuple(eqs),
            result.last,
            tuple(sp.Poly(f.as_expr().subs(reveal), f.gens) for f in result.factors),
            tuple((u, e.subs(reveal)) for u, e in result.back_substitution),
        )
        if not special_points:
            return general
        special = []
        for name in self.special_points:
            at = {self.model.symbols[name]: sp.Integer(0)}
            if self._breaks_at(general, at):
                solved = self.derive(labels, at, special_points=False)
                if solved.identifiable:
                    special.append((name, solved))
        return dataclasses.replace(general, special=tuple(special))

    def _undetermined(self, labels: tuple[str, ...], rank: int, free: tuple[str, ...]) -> InverseSet:
        """The set that fixes only ``rank`` combinations of the unknowns, naming those left ``free``."""
        names = ", ".join(self.model.description.unknown)
        return InverseSet(
            labels,
            False,
            f"these frequencies fix only {counted(rank, 'independent combination')} of the "
            f"{counted(len(self.unknowns), 'unknown')} ({names}); {', '.join(free)} "
            f"{'is' if len(free) == 1 else 'are'} not determined",
            undetermined=free,
        )

    def _solve(self, labels: tuple[str, ...], eqs: list[sp.Expr], lams: list[sp.Symbol]) -> InverseSet:
        """Triangularise the polynomial system by directed elimination.

        While more than one unknown remains, pick an equation linear in some unknown, solve it for that
        unknown (among all such choices the one with the fewest subtractions, see _cancellation_score) and
        substitute into the other equations (numerators only). The last equation is a polynomial in the last
        unknown; it is factored over the parameters. Clearing denominators may add factors whose roots are
        not solutions (e.g. an unknown = 0): the run-time admissibility check removes them.
        """
        # The last unknown comes from the smallest square subsystem (as many equations as unknowns in
        # them, e.g. both roots of one block): its polynomial then separates that subsystem's solutions.
        # An unknown outside it may take (nearly) the same value in several solutions: a near-double root.
        for size in range(1, len(eqs) + 1):
            keeps: list[sp.Symbol] = []  # each candidate once, in order of first appearance
            for subset in itertools.combinations(eqs, size):
                inside = set().union(*(e.free_symbols for e in subset)) & set(self.unknowns)
                if len(inside) == size:
                    keeps += [k for k in sorted(inside, key=str) if k not in keeps]
            best = None
            for keep in keeps:
                result = self._eliminate(labels, eqs, lams, keep)
                if result.identifiable:
                    score = (
                        max(f.degree() for f in result.factors),
                        sum(map(sp.count_ops, [f.as_expr() for f in result.factors])),
                    )
                    if best is None or score < best[0]:
                        best = (score, result)
            if best is not None:
                return best[1]
        return InverseSet(
            labels, True, "no closed form of manageable size (solved numerically)", tuple(lams), numeric=True
        )

    def _eliminate(
        self, labels: tuple[str, ...], eqs: list[sp.Expr], lams: list[sp.Symbol], keep: sp.Symbol
    ) -> InverseSet:
        """Eliminate every unknown but ``keep`` (see _solve)."""
        unknowns = list(self.unknowns)
        system = [sp.expand(e) for e in eqs]
        steps: list[tuple[sp.Symbol, sp.Expr]] = []
        while len(unknowns) > 1:
            options = []
            for k, e in enumerate(system):
                for u in unknowns:
                    if u == keep:
                        continue
                    linear = self._linear_solution(e, u)
                    if linear is not None:
                        score, sol = linear
                        options.append((score, unknowns.index(u), k, u, sol))
            if not options:
                return InverseSet(labels, False, "no equation is linear in a remaining unknown (not generated)")
            _, _, k, u, sol = min(options, key=lambda o: (o[0], -o[1], o[2]))
            steps.append((u, sol))
            unknowns.remove(u)
            rest = [system[j] for j in range(len(system)) if j != k]
            system = []
            num_sol, den_sol = sp.fraction(sol)
            width = _terms(sp.expand(num_sol)) + _terms(sp.expand(den_sol))
            for e in rest:
                if _terms(e) * width ** sp.Poly(e, u).degree() > self.settings.max_substitution:
                    return InverseSet(
                        labels, False, f"eliminating {u} would swell past {self.settings.max_substitution} terms"
                    )
                num = sp.expand(sp.numer(sp.together(e.subs(u, sol))))
                if _terms(num) > self.settings.max_terms:
                    return InverseSet(labels, False, f"eliminating {u} leaves an equation of {_terms(num)} terms")
                if num != 0:
                    system.append(num)
        last = unknowns[0]
        candidates = [e for e in system if e.has(last)]
        if not candidates:
            return InverseSet(labels, False, f"the equations leave {last} free (not generated)")
        univariate = min(candidates, key=lambda e: (sp.degree(e, last), sp.count_ops(e)))
        factors = _factors_in(sp.Poly(univariate, last))
        back = [(str(u), sol) for u, sol in reversed(steps)]
        return InverseSet(labels, True, "", tuple(lams), tuple(eqs), str(last), tuple(factors), tuple(back))

    def _linear_solution(self, e: sp.Expr, u: sp.Symbol) -> tuple[tuple[int, int, int], sp.Expr] | None:
        """(score, factored solution) of an equation linear in ``u``, None otherwise; memoised, since every
        choice of the last unknown in _solve starts from the same system."""
        key = (e, u)
        if key not in self._linear:
            by_power: dict[int, list[sp.Expr]] = {}
            for term in sp.Add.make_args(e):  # e is expanded: each term is a monomial times coefficients
                power = term.as_powers_dict().get(u, 0)
                by_power.setdefault(int(power), []).append(term)
            if set(by_power) in ({1}, {0, 1}):
                a1 = sp.Add(*by_power[1]) / u
                a0 = sp.Add(*by_power.get(0, []))
                # factoring finds the form with the fewest subtractions; on a large equation it costs seconds
                # and the set is on its way to the size limit anyway
                sol = factor(-a0 / a1) if _terms(e) <= self.settings.factor_terms else -a0 / a1
                self._linear[key] = (_cancellation_score(sol), sol)
            else:
                self._linear[key] = None
        return self._linear[key]

    def candidates(self) -> list[tuple[str, ...]]:
        """Every set of distinct frequencies as large as the number of unknowns."""
        return list(itertools.combinations(self.structure.unique_labels, len(self.unknowns)))

    def all_sets(self) -> list[InverseSet]:
        """derive() of every candidate set, in order (python -m mountid.engine.codegen spreads them over processes)."""
        return [self.derive(c) for c in self.candidates()]
