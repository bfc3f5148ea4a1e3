"""Traceability: which region of a block computes which model term, and from which constants."""
from __future__ import annotations

from thermoplc.generator.ir import Block, Ref, Index, walk_exprs
from thermoplc.generator.literals import real_literal
from thermoplc.generator.stats import block_stats


def explain(block: Block) -> str:
    """One paragraph per region: its title (the model term), its cost and the constants it reads."""
    constants = {c.name: c for c in block.constants}
    tables = {v.name: v for v in block.statics if v.initial is not None}
    costs = block_stats(block)["regions"]
    lines = [f"block {block.name}: {len(block.regions)} regions, {len(constants)} named constants"]
    for number, region in enumerate(block.regions, start=1):
        used = []
        for e in walk_exprs(region.body):
            name = e.name if isinstance(e, (Ref, Index)) else None
            if name and (name in constants or name in tables) and name not in used:
                used.append(name)
        ops = costs[number - 1][1]
        arithmetic = sum(v for k, v in ops.items() if k not in ("assign", "compare", "logic", "index"))
        lines.append(f"{number:>3}. {region.title}")
        lines.append(f"     {arithmetic} arithmetic operations, {ops.get('compare', 0)} comparisons per call")
        for name in used:
            if name in constants:
                c = constants[name]
                value = real_literal(c.value) if c.type == "REAL" else str(c.value)
                lines.append(f"     {name} = {value}" + (f"   ({c.comment})" if c.comment else ""))
            else:
                lines.append(f"     {name}: table of {tables[name].length} values   ({tables[name].comment})")
    return "\n".join(lines)
