"""The intermediate model form every other part of colloc works on.

A :class:`Model` is the implicit first-order system ``F(x', x, r, p, t) = 0`` with named
states ``x``, inputs ``r`` (controlled, known exogenous, unknown exogenous), constant
parameters ``p`` and measured outputs ``y = g(x, r, t)``. Mechanical systems stay implicit
(``M(q) u' - f = 0``): the mass matrix is never inverted.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Protocol, TypeAlias

import sympy as sm

from colloc.model.errors import raise_if_any
from colloc.model.schedule import ParameterSchedule
from colloc.model.symbols import (
    TIME,
    as_tuple,
    derivatives_in,
    functions_of_time,
    is_function_of_time,
    name_of,
    sort_by_name,
)
from colloc.model.validation import output_problems, validate_model

if TYPE_CHECKING:
    from sympy.physics.mechanics import KanesMethod, LagrangesMethod

Inputs: TypeAlias = sm.Basic | Sequence[sm.Basic] | sm.MatrixBase | None


class Controller(Protocol):
    """What :meth:`Model.close_loop` needs from a controller."""

    def control_law(self, model: Model) -> Mapping[sm.Basic, sm.Expr]:
        """Map each controlled input the controller drives to its expression."""
        ...  # pragma: no cover

    @property
    def parameters(self) -> tuple[sm.Symbol, ...]:
        """The controller's constants (gains, set points) that become model parameters."""
        ...  # pragma: no cover


@dataclass(frozen=True)
class Model:
    """Implicit dynamic model ``F(x', x, r, p, t) = 0`` with outputs ``y = g(x, r, t)``.

    Build one with :meth:`from_kane`, :meth:`from_lagrange` or :meth:`from_equations`
    rather than directly; those validate the definition and report every problem at once.

    Attributes
    ----------
    residual : sympy.Matrix
        ``F``, one row per equation.
    states : tuple
        The states ``x(t)`` (functions of time).
    controlled_inputs, known_inputs, unknown_inputs : tuple
        Inputs ``r(t)`` driven by a controller, measured, or to be estimated.
    parameters : tuple
        Constant symbols ``p`` of the model, sorted by name.
    outputs : dict
        Output symbol -> expression ``g(x, r, t)`` (after :meth:`close_loop`, a controlled
        input in an output is the controller's law, so the output may hold its parameters).
    controller_parameters : tuple
        The subset of ``parameters`` introduced by :meth:`close_loop`.
    schedules : tuple of ParameterSchedule
        Parameters scheduled over a phase (e.g. by :class:`colloc.GainScheduled`); the
        residual holds their slot symbols and weights, ``parameters`` their points.
    t : sympy.Symbol
        Time.
    initial_constraints : tuple of sympy.Expr
        Expressions in the states and parameters that equal zero at the first time of a
        problem: the position- and velocity-level constraints that the residual holds only
        differentiated (:meth:`from_lagrange` with constraints). A :class:`colloc.Problem`
        imposes them at its first node.
    inertia : sympy.ImmutableMatrix or None
        For a mechanical model (:meth:`from_kane` without nonholonomic constraints,
        :meth:`from_lagrange`): the mass matrix ``M(q)`` of the dynamic equations, in the
        states and parameters; a :class:`colloc.Problem` checks that it is positive definite
        with the known parameter values.
    """

    residual: sm.Matrix
    states: tuple[sm.Basic, ...]
    controlled_inputs: tuple[sm.Basic, ...] = ()
    known_inputs: tuple[sm.Basic, ...] = ()
    unknown_inputs: tuple[sm.Basic, ...] = ()
    parameters: tuple[sm.Symbol, ...] = ()
    outputs: dict[sm.Basic, sm.Expr] = field(default_factory=dict)
    controller_parameters: tuple[sm.Symbol, ...] = ()
    t: sm.Symbol = TIME
    schedules: tuple[ParameterSchedule, ...] = ()
    initial_constraints: tuple[sm.Expr, ...] = ()
    inertia: sm.ImmutableMatrix | None = None

    # ------------------------------------------------------------------ derived views
    @property
    def state_derivatives(self) -> tuple[sm.Basic, ...]:
        """``x'(t)`` in the order of :attr:`states`."""
        return tuple(x.diff(self.t) for x in self.states)

    @property
    def algebraic_states(self) -> tuple[sm.Basic, ...]:
        """States whose derivative appears in no equation (e.g. Lagrange multipliers)."""
        derivatives = self.residual.atoms(sm.Derivative)
        return tuple(x for x in self.states if x.diff(self.t) not in derivatives)

    @property
    def inputs(self) -> tuple[sm.Basic, ...]:
        """All inputs: controlled, then known, then unknown."""
        return self.controlled_inputs + self.known_inputs + self.unknown_inputs

    @property
    def num_states(self) -> int:
        """Number of states ``n``."""
        return len(self.states)

    @property
    def num_equations(self) -> int:
        """Number of residual rows."""
        return self.residual.shape[0]

    def __repr__(self) -> str:
        names = ", ".join(name_of(x) for x in self.states)
        return (
            f"Model(states=[{names}], equations={self.num_equations}, "
            f"inputs={[name_of(r) for r in self.inputs]}, "
            f"parameters={[name_of(p) for p in self.parameters]})"
        )

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_equations(
        cls,
        residual: sm.MatrixBase | Sequence[sm.Expr],
        states: Inputs,
        *,
        controlled_inputs: Inputs = None,
        known_inputs: Inputs = None,
        unknown_inputs: Inputs = None,
        outputs: Mapping[sm.Basic, sm.Expr] | Sequence[sm.Basic] | None = None,
        parameters: Inputs = None,
        t: sm.Symbol = TIME,
        input_derivatives: Mapping[sm.Basic, sm.Basic] | None = None,
        infer_inputs: bool = True,
    ) -> Model:
        """Build a model from a plain SymPy residual ``F(x', x, r, p, t) = 0``.

        Parameters
        ----------
        residual : sympy.Matrix or sequence of sympy.Expr
            The equations, each equal to zero, written in ``x(t)``, ``x(t).diff(t)``, inputs,
            constants and ``t``.
        states : sequence of functions of time
            The states ``x(t)``, one per equation.
        controlled_inputs, known_inputs, unknown_inputs : sequence of functions of time
            Every other function of time in the residual must be listed in exactly one.
        outputs : mapping or sequence, optional
            Measured outputs ``y = g(x, r, t)``: a mapping output symbol -> expression, or a
            sequence of states or inputs that are measured directly (e.g. joint torques
            from inverse dynamics). Default: every state.
        parameters : sequence of sympy.Symbol, optional
            The constants. If given, any other constant in the residual is reported as
            unknown; if omitted, every free symbol other than ``t`` is a parameter.
        t : sympy.Symbol
            The time symbol (``dynamicsymbols._t`` unless the model was built with another).
        input_derivatives : mapping, optional
            Input ``v(t)`` -> a new function of time ``a(t)`` standing for ``v'(t)``: an
            input that enters the equations through its derivative, such as a platform's
            acceleration ``a`` in a plant written in the platform speed ``v``. Each ``v'`` in
            the residual is replaced by ``a``, and ``a`` joins the known inputs unless it is
            declared elsewhere (give its trajectory to :class:`colloc.Problem`).
        infer_inputs : bool
            Functions of time in the residual that are declared nowhere (and not
            differentiated) become known inputs, with a :class:`UserWarning` naming them;
            ``False`` makes them an error.

        Returns
        -------
        Model

        Raises
        ------
        ModelError
            Listing every problem found in the definition.
        """
        res = sm.Matrix(residual) if not isinstance(residual, sm.MatrixBase) else residual
        res = sm.Matrix(res).reshape(len(res), 1) if res.shape[1] != 1 else sm.Matrix(res)
        if input_derivatives:
            derivative_problems = _input_derivative_problems(input_derivatives, t)
            raise_if_any(derivative_problems)
            res = res.subs({v.diff(t): a for v, a in input_derivatives.items()})
            declared = {*as_tuple(controlled_inputs), *as_tuple(unknown_inputs)}
            known_inputs = as_tuple(known_inputs) + tuple(
                a
                for a in input_derivatives.values()
                if a not in declared and a not in as_tuple(known_inputs)
            )
        xs = as_tuple(states)
        if outputs is None:
            out: dict[sm.Basic, sm.Expr] = {x: x for x in xs}
        elif isinstance(outputs, Mapping):
            out = dict(outputs)
        else:
            out = {y: y for y in as_tuple(outputs)}
        ctrl, known, unknown = (
            as_tuple(v) for v in (controlled_inputs, known_inputs, unknown_inputs)
        )
        given_params = None if parameters is None else as_tuple(parameters)
        if infer_inputs:
            inferred = _undeclared_inputs(res, (*xs, *ctrl, *known, *unknown), t)
            if inferred:
                warnings.warn(
                    f"functions of time {[name_of(f) for f in inferred]} appear in the "
                    "residual but are declared nowhere: taken as known inputs (declare them "
                    "to silence this, or pass infer_inputs=False to make it an error)",
                    UserWarning,
                    stacklevel=2,
                )
                known = known + inferred
        problems, found_params = validate_model(res, xs, ctrl, known, unknown, out, given_params, t)
        raise_if_any(problems)
        params = sort_by_name(given_params if given_params is not None else found_params)
        return cls(res, xs, ctrl, known, unknown, params, out, (), t)  # type: ignore[arg-type]

    @classmethod
    def from_kane(
        cls,
        kane: KanesMethod,
        *,
        controlled_inputs: Inputs = None,
        known_inputs: Inputs = None,
        unknown_inputs: Inputs = None,
        outputs: Mapping[sm.Basic, sm.Expr] | Sequence[sm.Basic] | None = None,
        parameters: Inputs = None,
        t: sm.Symbol = TIME,
        input_derivatives: Mapping[sm.Basic, sm.Basic] | None = None,
    ) -> Model:
        """Build a model from a :class:`sympy.physics.mechanics.KanesMethod`.

        The states are ``[q, u]``; the residual stacks the kinematic differential equations
        ``M_k(q) q' - f_k(q, u) = 0`` and the dynamic equations ``M(q) u' - f(q, u, r) = 0``
        (with nonholonomic constraints, SymPy's square augmented form). Outputs default to
        the generalized coordinates.

        Parameters
        ----------
        kane : KanesMethod
            With ``kanes_equations`` already called.
        controlled_inputs, known_inputs, unknown_inputs, outputs, parameters, t
            As in :meth:`from_equations`.
        input_derivatives : mapping, optional
            As in :meth:`from_equations`: e.g. ``{v: a}`` when the platform speed ``v(t)``
            is a known input and its derivative, which Kane's equations hold, is the known
            acceleration ``a(t)``.

        Returns
        -------
        Model
        """
        if getattr(kane, "_fr", None) is None:
            raise TypeError(
                "kane: expected a KanesMethod whose kanes_equations() has been called; "
                "found one without equations"
            )
        q, u = tuple(kane.q), tuple(kane.u)
        qd = sm.Matrix([qi.diff(t) for qi in q])
        ud = sm.Matrix([ui.diff(t) for ui in u])
        kin = kane.mass_matrix_kin * qd - kane.forcing_kin
        dyn = kane.mass_matrix * ud - kane.forcing
        model = cls.from_equations(
            kin.col_join(dyn),
            q + u,
            controlled_inputs=controlled_inputs,
            known_inputs=known_inputs,
            unknown_inputs=unknown_inputs,
            outputs=q if outputs is None else outputs,
            parameters=parameters,
            t=t,
            input_derivatives=input_derivatives,
        )
        if len(getattr(kane, "_udep", ())) or kane.mass_matrix.shape[0] != len(u):
            return model  # nonholonomic: SymPy's augmented mass matrix is not symmetric
        return replace(model, inertia=sm.ImmutableMatrix(kane.mass_matrix))

    @classmethod
    def from_lagrange(
        cls,
        lagrange: LagrangesMethod,
        *,
        controlled_inputs: Inputs = None,
        known_inputs: Inputs = None,
        unknown_inputs: Inputs = None,
        outputs: Mapping[sm.Basic, sm.Expr] | Sequence[sm.Basic] | None = None,
        parameters: Inputs = None,
        speed_prefix: str = "u_",
        t: sm.Symbol = TIME,
        input_derivatives: Mapping[sm.Basic, sm.Basic] | None = None,
    ) -> Model:
        """Build a model from a :class:`sympy.physics.mechanics.LagrangesMethod`.

        New speed states ``u_q(t) = q'(t)`` make the system first order: states are
        ``[q, u]`` and, with constraints, the Lagrange multipliers ``lam`` as algebraic
        states, closed by the constraints differentiated to the acceleration level
        (``d/dt`` of SymPy's velocity-level ``coneqs``: an index-1 system, whose multipliers
        every collocation scheme determines). The position- and velocity-level constraints
        become the model's :attr:`initial_constraints`, which a :class:`colloc.Problem`
        imposes at its first node, so they hold along the motion to the scheme's accuracy;
        their constants (a rod length) join the parameters. (Closed by the velocity-level
        equations instead, the midpoint rule leaves the speeds an alternating mode that
        the multipliers absorb.)

        Parameters
        ----------
        lagrange : LagrangesMethod
            With ``form_lagranges_equations`` already called.
        speed_prefix : str
            Prefix of the names of the speed states created for each coordinate.
        controlled_inputs, known_inputs, unknown_inputs, outputs, parameters, t
            As in :meth:`from_equations`.
        input_derivatives : mapping, optional
            As in :meth:`from_equations`.

        Returns
        -------
        Model
        """
        from sympy.physics.mechanics import dynamicsymbols

        if getattr(lagrange, "eom", None) is None:
            raise TypeError(
                "lagrange: expected a LagrangesMethod whose form_lagranges_equations() has been "
                "called; found one without equations"
            )
        q = tuple(lagrange.q)
        u = tuple(dynamicsymbols(f"{speed_prefix}{name_of(qi)}") for qi in q)
        if t != TIME:
            u = tuple(sm.Function(name_of(ui))(t) for ui in u)
        to_first_order: dict[sm.Basic, sm.Basic] = {}
        for qi, ui in zip(q, u, strict=True):
            to_first_order[qi.diff(t, 2)] = ui.diff(t)
            to_first_order[qi.diff(t)] = ui
        lam = tuple(lagrange.lam_vec)
        kin = sm.Matrix([qi.diff(t) - ui for qi, ui in zip(q, u, strict=True)])
        # eom already holds M q'' - f with the multiplier terms when constraints exist.
        dyn = sm.Matrix(lagrange.eom).xreplace(to_first_order)
        rows = kin.col_join(dyn)
        at_start: list[sm.Expr] = []
        if lam:
            velocity_level = sm.Matrix(lagrange.coneqs)
            rows = rows.col_join(velocity_level.diff(t).xreplace(to_first_order))
            # SymPy keeps the position-level constraints only privately.
            position_level = sm.Matrix(getattr(lagrange, "_hol_coneqs", sm.Matrix()))
            at_start = [*position_level, *velocity_level.xreplace(to_first_order)]
        model = cls.from_equations(
            rows,
            q + u + lam,
            controlled_inputs=controlled_inputs,
            known_inputs=known_inputs,
            unknown_inputs=unknown_inputs,
            outputs=q if outputs is None else outputs,
            parameters=parameters,
            t=t,
            input_derivatives=input_derivatives,
        )
        # with constraints SymPy appends the multipliers' columns: M is the first n
        mass = sm.Matrix(lagrange.mass_matrix)[:, : len(q)].xreplace(to_first_order)
        model = replace(model, inertia=sm.ImmutableMatrix(mass))
        if not at_start:
            return model
        constants = set().union(*(e.free_symbols for e in at_start)) - {t}
        missing = constants - set(model.parameters)
        if parameters is not None and missing:
            raise_if_any(
                [
                    f"parameters: the constraints hold {name_of(c)}, which is not listed "
                    f"(listed: {[name_of(p) for p in model.parameters]})"
                    for c in sort_by_name(missing)
                ]
            )
        return replace(
            model,
            parameters=sort_by_name(set(model.parameters) | constants),  # type: ignore[arg-type]
            initial_constraints=tuple(at_start),
        )

    # ------------------------------------------------------------------ operations
    def close_loop(self, controller: Controller) -> Model:
        """Substitute a controller's law for the controlled inputs it drives.

        Parameters
        ----------
        controller : Controller
            For example :class:`colloc.StateFeedback`. Its constants become model
            parameters, which a :class:`colloc.Problem` can treat as known or unknown.

        Returns
        -------
        Model
            The closed-loop model; controlled inputs the controller does not drive remain.
            Outputs that hold a driven input now hold the controller's law in its place.
        """
        law = dict(controller.control_law(self))
        problems = [
            f"controller drives {name_of(r)}, which is not a controlled input of the model "
            f"(controlled inputs: {[name_of(c) for c in self.controlled_inputs]})"
            for r in law
            if r not in self.controlled_inputs
        ]
        clash = set(controller.parameters) & (set(self.parameters) | set(self.states))
        problems += [
            f"controller parameter {name_of(p)} is already used by the model" for p in clash
        ]
        raise_if_any(problems)
        residual = self.residual.xreplace(law)
        outputs = {y: g.xreplace(law) for y, g in self.outputs.items()}
        at_start = tuple(e.xreplace(law) for e in self.initial_constraints)
        remaining = tuple(r for r in self.controlled_inputs if r not in law)
        schedules = tuple(getattr(controller, "schedules", ()))
        phases = tuple(dict.fromkeys(s.phase for s in schedules if s.phase not in self.inputs))
        new_params = sort_by_name(set(self.parameters) | set(controller.parameters))
        return replace(
            self,
            residual=residual,
            outputs=outputs,
            controlled_inputs=remaining,
            known_inputs=self.known_inputs + phases,
            parameters=new_params,  # type: ignore[arg-type]
            controller_parameters=self.controller_parameters + tuple(controller.parameters),
            schedules=self.schedules + schedules,
            initial_constraints=at_start,
        )

    def with_disturbances(self, disturbances: Mapping[int | sm.Basic, sm.Basic]) -> Model:
        """Add unknown disturbance trajectories (process noise) to equations or inputs.

        A disturbance keyed by an equation row ``i`` makes that equation
        ``F_i(x', x, r, p, t) - w_i(t) = 0``: for the dynamic rows of :meth:`from_kane` /
        :meth:`from_lagrange` (``M u' - f = 0``) a generalized force added to ``f`` on that
        coordinate (a residual force on an unactuated one). A disturbance keyed by an input
        ``r`` replaces ``r`` by ``r + w(t)`` in the equations and the outputs: noise on an
        actuator (motor noise on a joint torque, before :meth:`close_loop` puts the
        controller's law in place of ``r``) or on a known input. The ``w`` join
        :attr:`unknown_inputs`, so a :class:`colloc.Problem` estimates them at every node;
        give their standard deviations as the problem's ``process_noise`` to penalise them
        by their variance (the maximum a posteriori form; see ``docs/process-noise.md``).
        With every dynamic row disturbed, any state trajectory satisfies the dynamics for
        ``w = F``: a start consistent with the equations by construction.

        Parameters
        ----------
        disturbances : mapping
            Equation row (from 0) or input of the model -> a new function of time, e.g.
            ``dynamicsymbols("w_hip")``.

        Returns
        -------
        Model

        Raises
        ------
        ModelError
            Listing every row out of range, every key that is neither a row nor an input and
            every symbol that is not a new function of time or is given twice.
        """
        problems = []
        if not isinstance(disturbances, Mapping) or not disturbances:
            raise_if_any(
                [
                    "disturbances: expected a non-empty mapping (equation row or input) -> "
                    f"function of time, found {disturbances!r}"
                ]
            )
        used = set(self.states) | set(self.inputs)
        seen: set[sm.Basic] = set()
        for key, w in disturbances.items():
            if key in self.inputs:
                pass
            elif (
                isinstance(key, bool)
                or not isinstance(key, int)
                or not 0 <= key < self.num_equations
            ):
                problems.append(
                    f"disturbances: row {key!r} is not an equation of the model "
                    f"(rows 0 to {self.num_equations - 1}) nor one of its inputs "
                    f"{[name_of(r) for r in self.inputs]}"
                )
            if not is_function_of_time(w, self.t):
                problems.append(
                    f"disturbances: {w!r} for row {key!r} is not a function of {self.t} "
                    "(make one with sympy.physics.mechanics.dynamicsymbols)"
                )
            elif w in used:
                problems.append(f"disturbances: {name_of(w)} is already a state or input")
            elif w in seen:
                problems.append(f"disturbances: {name_of(w)} is given for two rows")
            seen.add(w)
        raise_if_any(problems)
        on_inputs = {r: r + w for r, w in disturbances.items() if r in self.inputs}
        residual = sm.Matrix(self.residual).xreplace(on_inputs)
        for row, w in disturbances.items():
            if isinstance(row, int):
                residual[row] = residual[row] - w
        outputs = {y: g.xreplace(on_inputs) for y, g in self.outputs.items()}
        return replace(
            self,
            residual=residual,
            outputs=outputs,
            initial_constraints=tuple(e.xreplace(on_inputs) for e in self.initial_constraints),
            unknown_inputs=self.unknown_inputs + tuple(disturbances.values()),
        )

    def with_outputs(
        self,
        outputs: Mapping[sm.Basic, sm.Expr] | Sequence[sm.Basic],
        parameters: Sequence[sm.Symbol] = (),
    ) -> Model:
        """Return a copy with other measured outputs (validated like the constructors).

        Parameters
        ----------
        outputs : mapping or sequence
            Output symbol -> expression ``g(x, r, p, t)`` in the states, inputs and
            parameters, or a sequence of states or inputs measured directly.
        parameters : sequence of sympy.Symbol
            Constants that only the outputs hold, added to :attr:`parameters` (e.g. where a
            marker sits on its segment, estimated with the motion). Each must appear in an
            output and not already be a parameter or a function of time.

        Returns
        -------
        Model

        Raises
        ------
        ModelError
            Naming every output that depends on something other than the states, the inputs
            and ``t``, holds a derivative or is not an expression, and every added parameter
            that is not a new plain symbol held by an output.
        """
        out = dict(outputs) if isinstance(outputs, Mapping) else {y: y for y in as_tuple(outputs)}
        problems = output_problems(out, self.states, self.t, self.inputs)
        added = as_tuple(parameters)
        held: set[sm.Basic] = set()
        for g in out.values():
            if isinstance(g, sm.Basic):
                held |= g.free_symbols
        for p in added:
            if not isinstance(p, sm.Symbol) or p == self.t:
                problems.append(f"parameters: expected plain SymPy symbols, found {p!r}")
            elif p in self.parameters:
                problems.append(f"parameters: {name_of(p)} is already a parameter of the model")
            elif p not in held:
                problems.append(f"parameters: {name_of(p)} appears in no output")
        if len(set(added)) != len(added):
            problems.append("parameters: a symbol is given twice")
        raise_if_any(problems)
        if not added:
            return replace(self, outputs=out)
        merged = tuple(sorted((*self.parameters, *added), key=name_of))
        return replace(self, outputs=out, parameters=merged)

    def describe(self) -> dict[str, Any]:
        """A plain summary (names only) for logs and result records."""
        return {
            "states": [name_of(x) for x in self.states],
            "controlled_inputs": [name_of(r) for r in self.controlled_inputs],
            "known_inputs": [name_of(r) for r in self.known_inputs],
            "unknown_inputs": [name_of(r) for r in self.unknown_inputs],
            "parameters": [name_of(p) for p in self.parameters],
            "outputs": [name_of(y) for y in self.outputs],
            "num_equations": self.num_equations,
        }


def _input_derivative_problems(mapping: Mapping[sm.Basic, sm.Basic], t: sm.Symbol) -> list[str]:
    """What is wrong with an ``input_derivatives`` mapping (input -> its derivative's name)."""
    if not isinstance(mapping, Mapping):
        return [
            "input_derivatives: expected a mapping input v(t) -> new function a(t) standing "
            f"for v'(t), found {type(mapping).__name__}"
        ]
    problems = []
    for v, a in mapping.items():
        for label, f in (("key", v), ("value", a)):
            if not is_function_of_time(f, t):
                problems.append(
                    f"input_derivatives: expected each {label} to be a function of time "
                    f"{name_of(t)} such as v({name_of(t)}), found {f!r}"
                )
    return problems


def _undeclared_inputs(
    residual: sm.Matrix, declared: tuple[sm.Basic, ...], t: sm.Symbol
) -> tuple[sm.Basic, ...]:
    """Functions of time in ``residual`` declared nowhere and never differentiated."""
    differentiated = {d.expr for d in derivatives_in(residual)}
    found = functions_of_time(residual, t) - set(declared) - differentiated
    return tuple(sorted(found, key=name_of))
