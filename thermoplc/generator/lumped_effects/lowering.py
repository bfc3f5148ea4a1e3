"""The record of what one named effect adds to the lumped-mass block, by the place it takes in the
block's per-call order (models/kinds/lumped_model.py's docstring gives that order). Each hook returns IR
only; the lumped lowering (generator/lower_lumped.py) calls the hooks of the model's effects in the
order of their rank, so a new effect's block arithmetic is a new module of this package."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from thermoplc.generator.ir import Assign, BinOp, Const, Ref, Region, Stmt, Var
from thermoplc.generator.lower_shared import const
from thermoplc.models.model import Model


@dataclass(frozen=True)
class Lumped:
    """What every hook may read: the model and the block's names for its signals."""
    model: Model
    speed: Ref
    ambient: Ref
    structure: bool  # the identified structure lag L_i is in the block


@dataclass(frozen=True)
class State:
    """State an effect adds: set at the first call, declared static, and the constants it needs."""
    init: tuple[Assign, ...] = ()
    statics: tuple[Var, ...] = ()
    constants: tuple[Const, ...] = ()


@dataclass(frozen=True)
class Speed:
    """How speed becomes the heat input S instead of S := n: the region computing it and its statics."""
    region: Region
    statics: tuple[Var, ...] = ()


def _no_state(*_) -> State:
    return State()


def _nothing(*_) -> tuple:
    return ()


@dataclass(frozen=True)
class EffectLowering:
    """An effect's part of the lumped block; every hook defaults to adding nothing."""
    name: str  # the effect's name (physics/effects)
    comments: tuple[tuple[str, str], ...] = ()  # the comment of each of its constants, by stem (G2 for c_G2_1)
    table_stems: tuple[str, ...] = ()  # coefficients it declares as read-only tables (node for node_1..), not constants
    speed: Callable[[Lumped], Speed | None] | None = None  # S from the speed, or None for S := n
    sensor_state: Callable[[Lumped, int], State] = _no_state  # per sensor i, after Tsim_i, T0_i (and L_i)
    heat_lags: Callable[[Lumped], tuple[Stmt, ...]] = _nothing  # per call before the sensors: heat entering late
    heat: Callable[[Lumped, int], tuple[Stmt, ...]] = _nothing  # statements adding to sensor i's heat input Q
    # (context, i, the lag's drive, the lag step) -> the step sensor i takes instead
    step: Callable[[Lumped, int, BinOp, Stmt], Stmt] | None = None
    after_step: Callable[[Lumped, int], tuple[Stmt, ...]] = _nothing  # after sensor i's step, filter and structure
    sensor_terms: Callable[[Lumped, int], tuple] = _nothing  # displacement terms of sensor i, after beta_i, gamma_i
    shared_state: Callable[[Lumped], State] = _no_state  # state shared by the sensors, after Te0
    shared: Callable[[Lumped], tuple[Stmt, ...]] = _nothing  # per call, after every sensor
    terms: Callable[[Lumped], tuple] = _nothing  # displacement terms after every sensor's
    closing_state: Callable[[Lumped], State] = _no_state  # state of what runs after the displacement
    closing: Callable[[Lumped], tuple[Region, ...]] = _nothing  # regions after the displacement (used next call)


def lag(state: str, decay: str, drive: str, source) -> Assign:
    """state := c_decay * state + c_drive * source: one first-order lag step, as the reference rounds it."""
    return Assign(state, BinOp("+", BinOp("*", const(decay), Ref(state)), BinOp("*", const(drive), source)))


def lag_state(name: str, comment: str, floor: str, floor_value: float, floor_comment: str) -> State:
    """An effect's own lag as block state: REAL `name` from c_Zero (which every block declares; the Reset starts
    each state from it) and the floor below which it is set to 0 before a long decay makes it subnormal."""
    return State(init=(Assign(name, const("Zero")),), statics=(Var(name, "REAL", comment),),
                 constants=(Const(floor, floor_value, floor_comment),))

