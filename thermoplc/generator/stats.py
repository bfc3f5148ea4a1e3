"""What a block costs on the PLC: operations per call (worst-case path) and bytes of state."""
from __future__ import annotations

from collections import Counter

from thermoplc.generator.ir import Assign, BinOp, Block, Call, For, Index, IntConst, Ref, Region, Unary

STATE_BYTES = {"REAL": 4, "INT": 2, "BOOL": 1}
_KIND = {"+": "add/sub", "-": "add/sub", "*": "mul", "/": "div", "<": "compare", "<=": "compare", ">": "compare",
         ">=": "compare", "=": "compare", "<>": "compare", "AND": "logic", "OR": "logic", "XOR": "logic"}


def _expr(e, tally: Counter) -> None:
    if isinstance(e, BinOp):
        tally[_KIND[e.op]] += 1
        _expr(e.left, tally)
        _expr(e.right, tally)
    elif isinstance(e, Unary):
        tally["logic" if e.op == "NOT" else "negate"] += 1
        _expr(e.operand, tally)
    elif isinstance(e, Call):
        tally[e.func.lower()] += 1
        for a in e.args:
            _expr(a, tally)
    elif isinstance(e, Index):
        tally["index"] += 1
        _expr(e.index, tally)


def _bound(e, constants: dict) -> int:
    if isinstance(e, IntConst):
        return e.value
    return int(constants[e.name].value) if isinstance(e, Ref) and e.name in constants else 0


def _stmts(body, constants: dict) -> Counter:
    tally: Counter = Counter()
    for s in body:
        if isinstance(s, Assign):
            tally["assign"] += 1
            _expr(s.value, tally)
            if s.index is not None:
                _expr(s.index, tally)
        elif isinstance(s, For):
            trips = _bound(s.stop, constants) - _bound(s.start, constants) + 1
            inner = _stmts(s.body, constants)
            tally.update({k: v * trips for k, v in inner.items()})
        elif isinstance(s, Region):
            tally.update(_stmts(s.body, constants))
        else:
            conditions: Counter = Counter()
            costs = []
            for cond, branch in s.branches:
                _expr(cond, conditions)
                costs.append(_stmts(branch, constants))
            costs.append(_stmts(s.orelse, constants))
            tally.update(conditions)
            tally.update(max(costs, key=lambda c: (sum(c.values()), _arithmetic(c))))  # ties: the costlier sums
    return tally


ARITHMETIC = ("add/sub", "mul", "div", "negate", "abs", "sqrt", "min", "max")


def _arithmetic(counts: Counter) -> int:
    return sum(counts[k] for k in ARITHMETIC)


def block_stats(block: Block) -> dict:
    constants = {c.name: c for c in block.constants}
    per_region = [(r.title, dict(_stmts(r.body, constants))) for r in block.regions]
    total: Counter = Counter()
    for _, counts in per_region:
        total.update(counts)
    state = sum(STATE_BYTES[v.type] * (v.length or 1) for v in (*block.outputs, *block.statics) if v.initial is None)
    tables = sum(STATE_BYTES[v.type] * (v.length or 1) for v in block.statics if v.initial is not None)
    return {"operations_per_call": dict(sorted(total.items())), "arithmetic_per_call":
            _arithmetic(total),
            "state_bytes": state, "table_bytes": tables, "constants": len(block.constants),
            "regions": per_region}


def format_stats(stats: dict, model_only: dict) -> str:
    """model_only: the stats of the model's statements alone, to show what the safety logic adds."""
    ops = ", ".join(f"{k} {v}" for k, v in stats["operations_per_call"].items())
    safety = stats["arithmetic_per_call"] - model_only["arithmetic_per_call"]
    return (f"cost per call (worst-case path): {stats['arithmetic_per_call']} REAL/INT arithmetic operations "
            f"(model {model_only['arithmetic_per_call']}, input guards and output limits {safety}); {ops}\n"
            f"state: {stats['state_bytes']} bytes, tables: {stats['table_bytes']} bytes, "
            f"named constants: {stats['constants']}")
