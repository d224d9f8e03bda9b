"""The layout of the free vector and of the constraint vector: index <-> meaning.

Free vector ``z = [node variables (N x n_node, node-major), interval variables
((N-1) x n_interval, interval-major), unknown parameters (q)]``; constraints are blocks of
equations, each block ``count`` items of ``rows`` equations, item-major.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np


@dataclass(frozen=True)
class ConstraintBlock:
    """``count`` items (intervals, nodes, ...) of ``rows`` equations each."""

    name: str
    rows: int
    count: int
    item: str  # "interval", "node" or "instance"
    row_names: tuple[str, ...] = ()
    offset: int = 0

    @property
    def size(self) -> int:
        """Number of constraint rows in the block."""
        return self.rows * self.count


@dataclass
class Layout:
    """Maps every index of the free and constraint vectors to its meaning and back.

    Parameters
    ----------
    times : ndarray
        Node times.
    node_names : list of str
        Variables at each node, in order.
    interval_names : list of str
        Variables inside each interval, in order.
    parameter_names : list of str
        Unknown parameters.
    """

    times: np.ndarray
    node_names: list[str]
    interval_names: list[str]
    parameter_names: list[str]
    blocks: list[ConstraintBlock] = field(default_factory=list)

    @property
    def num_nodes(self) -> int:
        """``N``."""
        return int(self.times.size)

    @property
    def num_node_variables(self) -> int:
        """Variables per node."""
        return len(self.node_names)

    @property
    def num_interval_variables(self) -> int:
        """Variables per interval."""
        return len(self.interval_names)

    @property
    def interval_offset(self) -> int:
        """Index of the first interval variable."""
        return self.num_nodes * self.num_node_variables

    @property
    def parameter_offset(self) -> int:
        """Index of the first unknown parameter."""
        return self.interval_offset + (self.num_nodes - 1) * self.num_interval_variables

    @property
    def num_variables(self) -> int:
        """Length of the free vector."""
        return self.parameter_offset + len(self.parameter_names)

    @property
    def num_constraints(self) -> int:
        """Length of the constraint vector."""
        return sum(b.size for b in self.blocks)

    def add_block(self, block: ConstraintBlock) -> ConstraintBlock:
        """Append a constraint block, setting its offset; returns the placed block."""
        placed = ConstraintBlock(
            block.name, block.rows, block.count, block.item, block.row_names, self.num_constraints
        )
        self.blocks.append(placed)
        return placed

    # ---------------------------------------------------------------- index -> meaning
    def describe_variable(self, i: int) -> str:
        """What free-vector entry ``i`` is, e.g. ``"q1 at node 17 (t = 0.17)"``."""
        self._check_index(i, self.num_variables, "i")
        if i < self.interval_offset:
            k, j = divmod(i, self.num_node_variables)
            return f"{self.node_names[j]} at node {k} (t = {self.times[k]:.6g})"
        if i < self.parameter_offset:
            k, j = divmod(i - self.interval_offset, self.num_interval_variables)
            return (
                f"{self.interval_names[j]} in interval {k} "
                f"[{self.times[k]:.6g}, {self.times[k + 1]:.6g}]"
            )
        return f"parameter {self.parameter_names[i - self.parameter_offset]}"

    def describe_constraint(self, j: int) -> str:
        """What constraint row ``j`` is, e.g. ``"Midpoint defect, equation 3 on interval 5"``."""
        self._check_index(j, self.num_constraints, "j")
        for b in self.blocks:
            if j < b.offset + b.size:
                k, r = divmod(j - b.offset, b.rows)
                row = b.row_names[r] if b.row_names else f"equation {r}"
                if b.item == "interval":
                    where = f"interval {k} [{self.times[k]:.6g}, {self.times[k + 1]:.6g}]"
                elif b.item == "node":
                    where = f"node {k} (t = {self.times[k]:.6g})"
                else:
                    where = "instance constraint"
                return f"{b.name}: {row}, {where}"
        raise AssertionError("unreachable: row beyond the last block")

    # ---------------------------------------------------------------- meaning -> index
    @cached_property
    def _parameter_position(self) -> dict[str, int]:
        # A dictionary, not list.index: a gain schedule has tens of thousands of parameters.
        return {name: i for i, name in enumerate(self.parameter_names)}

    def variable_index(self, name: str, node: int | None = None) -> int:
        """Index of node variable ``name`` at ``node``, or of unknown parameter ``name``."""
        if node is None:
            position = self._parameter_position.get(name)
            if position is None:
                shown = self.parameter_names[:20]
                more = (
                    ""
                    if len(self.parameter_names) <= 20
                    else f" and {len(self.parameter_names) - 20} more"
                )
                raise KeyError(f"name: {name!r} is not an unknown parameter ({shown}{more})")
            return self.parameter_offset + position
        if name not in self.node_names:
            raise KeyError(f"name: {name!r} is not a node variable ({self.node_names})")
        self._check_index(node, self.num_nodes, "node")
        return node * self.num_node_variables + self.node_names.index(name)

    def node_indices(self, name: str) -> np.ndarray:
        """Indices of node variable ``name`` at every node."""
        return self.variable_index(name, 0) + self.num_node_variables * np.arange(self.num_nodes)

    # ---------------------------------------------------------------- fill / extract
    def fill(
        self,
        node_values: Mapping[str, np.ndarray | float] | None = None,
        parameter_values: Mapping[str, float] | None = None,
        interval_values: Mapping[str, np.ndarray | float] | None = None,
        default: float = 0.0,
    ) -> np.ndarray:
        """Build a free vector from values by name (missing entries get ``default``)."""
        z = np.full(self.num_variables, float(default))
        nodes = z[: self.interval_offset].reshape(self.num_nodes, self.num_node_variables)
        for name, value in (node_values or {}).items():
            if name not in self.node_names:
                raise KeyError(f"node_values: {name!r} is not a node variable ({self.node_names})")
            nodes[:, self.node_names.index(name)] = self._column(value, self.num_nodes, name)
        n_iv = self.num_interval_variables
        if n_iv:
            inner = z[self.interval_offset : self.parameter_offset].reshape(
                self.num_nodes - 1, n_iv
            )
            for name, value in (interval_values or {}).items():
                if name not in self.interval_names:
                    raise KeyError(f"interval_values: {name!r} is not an interval variable")
                inner[:, self.interval_names.index(name)] = self._column(
                    value, self.num_nodes - 1, name
                )
        for name, value in (parameter_values or {}).items():
            z[self.variable_index(name)] = float(value)
        return z

    def node_matrix(self, z: np.ndarray) -> np.ndarray:
        """Node variables as an ``(N, n_node)`` view of ``z``."""
        return z[: self.interval_offset].reshape(self.num_nodes, self.num_node_variables)

    def interval_matrix(self, z: np.ndarray) -> np.ndarray:
        """Interval variables as an ``(N-1, n_interval)`` view of ``z``."""
        return z[self.interval_offset : self.parameter_offset].reshape(
            self.num_nodes - 1, self.num_interval_variables
        )

    def parameters(self, z: np.ndarray) -> dict[str, float]:
        """Unknown parameter values by name."""
        return {
            n: float(v)
            for n, v in zip(self.parameter_names, z[self.parameter_offset :], strict=True)
        }

    @staticmethod
    def _column(value: np.ndarray | float, length: int, name: str) -> np.ndarray:
        arr = np.asarray(value, dtype=float)
        if arr.ndim == 0:
            return np.full(length, float(arr))
        if arr.shape != (length,):
            raise ValueError(f"values of {name}: expected shape ({length},), found {arr.shape}")
        return arr

    @staticmethod
    def _check_index(i: int, size: int, label: str) -> None:
        if not 0 <= int(i) < size:
            raise IndexError(f"{label}: expected an index in [0, {size}), found {i}")
