"""The library's `generate`: a model file's model becomes block text only after every check the
command line makes (the acceptance gate, the static range proof, the stress replay), so the CLI,
the demo and a user's script write the same, checked blocks."""
from __future__ import annotations

from dataclasses import dataclass

from thermoplc.base.errors import UserError
from thermoplc.base.version import __version__
from thermoplc.contract.constants import expected
from thermoplc.generator.ir import Block, Identity
from thermoplc.generator.lower import lower, prove
from thermoplc.generator.printer import (DIALECTS, GenerationError, render, render_instance_db, render_plcopen,
                                        validate)
from thermoplc.generator.ranges import RangeProof
from thermoplc.fitting.acceptance import problem, quantisation_problem
from thermoplc.models.modelfile import Model
from thermoplc.models.safety import Limits
from thermoplc.verifier.parser import parse_text
from thermoplc.verifier.plcopen import read_plcopen
from thermoplc.verifier.stress import StressResult, stress


@dataclass(frozen=True)
class Generated:
    """A checked block: its text, its IR, and the evidence that it is safe to write."""
    text: str
    block: Block
    proof: RangeProof
    stressed: StressResult
    unvalidated: str | None  # why the model has not earned a block, when accept_unvalidated let it through


def becomes_block(model: Model, path: str) -> None:
    """Refuse to write a model file that no block can be made of: fit and diagnose check it before
    writing, so that a column named like one of the block's own variables (`Ready`, `K0_1`) is
    refused there and not only by `generate`. The block is lowered and checked by the rules every
    rendering checks (printer.validate); no text is rendered, no range proof or gate is run."""
    problem = block_problem(model)
    if problem:
        raise UserError(f"{path}: not written: the model could not become a block: {problem}; rename the column "
                        f"or the block")


def block_problem(model: Model) -> str | None:
    """Why no block can be made of `model` (lowered and checked as becomes_block checks it), or None."""
    try:
        validate(lower(model))
    except GenerationError as exc:
        return str(exc)
    return None


def accepted(model: Model, source: str, accept_unvalidated: bool = False) -> str | None:
    """Refuse a model that has not earned a block (no held-out evidence, or not clearly better than
    no compensation) unless accept_unvalidated; refuse, always, a float32 block that is not the
    model that was judged. Returns why the model is unvalidated when the flag let it through."""
    try:
        drift, why = quantisation_problem(model), problem(model)
    except UserError as exc:  # a malformed metrics field
        raise UserError(f"{source}: {exc}") from None
    if drift:
        raise UserError(f"{source}: {drift}; nothing written")
    if why and not accept_unvalidated:
        raise UserError(f"{source}: {why}; nothing written (--accept-unvalidated writes it anyway, and the "
                        "header says so)")
    return why


def generate(model: Model, source: str = "model", limits: Limits | None = None, dialect: str = "tia",
             plcopen: bool = False, identity: Identity | None = None, retain: bool = False,
             instance_db: str | None = None, accept_unvalidated: bool = False, output: str = "block") -> Generated:
    """The block for `model` as text of `dialect` (PLCopen XML around the iec dialect with `plcopen`),
    or a UserError naming `source` (the model file) when any check refuses it; `output` names the
    text in what the stress replay reports; `limits` None: Limits.for_model(model), from its recording's envelope."""
    limits = Limits.for_model(model) if limits is None else limits
    if dialect not in DIALECTS:
        raise UserError(f"dialect {dialect!r}: expected one of {', '.join(DIALECTS)}")
    if plcopen and dialect != "iec":
        raise UserError("--format plcopen wraps the iec dialect; add --dialect iec")
    if instance_db is not None and dialect != "step7":
        raise UserError("--instance-db writes a STEP 7 instance DB source; TIA and IEC targets create the instance "
                        "when the block is called")
    unvalidated = accepted(model, source, accept_unvalidated)
    try:
        block = lower(model, limits, identity, retain)
        text = render_plcopen(block, __version__) if plcopen else render(block, dialect)
        if instance_db is not None:
            text += render_instance_db(block, instance_db)
    except GenerationError as exc:
        raise UserError(f"{source}: cannot generate a block: {exc}") from None
    except UserError as exc:  # a coefficient the kind needs is missing
        raise UserError(str(exc).replace("model file:", f"{source}:", 1)) from None
    written = [c.name for c in block.constants] + [v.name for v in block.statics if v.initial is not None]
    unused = expected(model, limits, written)[2]
    if unused:  # verify would find them in no constant or table: the file is not what its kind writes
        raise UserError(f"{source}: field 'coefficients': {', '.join(unused[:5])}{' ...' if len(unused) > 5 else ''} "
                        f"not used by a {model.kind} model; was the file edited, or its 'kind' changed?")
    proof = prove(model, block, limits)
    if proof.problems:
        more = f" (and {len(proof.problems) - 3} more)" if len(proof.problems) > 3 else ""
        raise UserError(f"{source}: the range proof fails with every input inside its guard range: "
                        + "; ".join(proof.problems[:3]) + more + "; nothing written")
    program = read_plcopen(text, output) if plcopen else parse_text(text, output)  # what is written is stressed
    stressed = stress(program, model, limits, output)
    if stressed.problems:
        raise UserError(f"{source}: the block reaches a value that must not reach the NC with every input inside its "
                        f"guard range (stress replay): " + "; ".join(stressed.problems[:3]) + "; nothing written")
    return Generated(text, block, proof, stressed, unvalidated)
