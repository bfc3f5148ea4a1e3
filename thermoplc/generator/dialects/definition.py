"""The record of one ST dialect: everything that differs between the dialects thermoplc writes, from the statement
syntax to the test bench's data blocks and the way a block file is recognised. One module of this package per
dialect declares one (`DIALECT = DialectDefinition(...)`); the template holds the block's frame."""
from __future__ import annotations

import re
from dataclasses import dataclass

from thermoplc.generator.ir import PORTABLE_FUNCTIONS


@dataclass(frozen=True)
class Target:
    """What one data block (or one constant array) of a test bench may hold, and why."""
    chunk_bytes: int
    download_bytes: int  # the data a default test bench holds: one download on the smallest CPU of the family
    why: str


@dataclass(frozen=True)
class BenchSpelling:
    """How the test bench spells what differs beyond the block's own spelling (generator/testbench_text.py).
    The lines below are formatted with `name` (the bench's), `short` (its first 8 characters), `title` and
    `title_comment` (the title as a comment of this dialect)."""
    array: str
    comment: str  # a line comment's opening and closing
    data_blocks: bool  # the rows in global data blocks (Siemens) or in the bench's constant arrays (IEC)
    block_head: tuple[str, ...]  # the bench function block's first lines, its header
    section_indent: str  # before VAR_OUTPUT ... END_VAR
    declaration_indent: str  # before each variable of a section
    untyped_constants: bool = False  # the constants as CONST name := value; END_CONST (classic SCL)
    data_block_head: tuple[str, ...] = ()  # a data block's lines after DATA_BLOCK "name", its struct opened
    data_block_end: str = ""  # the line that closes its struct


@dataclass(frozen=True)
class DialectDefinition:
    """A dialect: its statement syntax (generator/printer.py), its test bench, what the CLI says of it."""
    name: str
    title: str  # how an engineer names it in a sentence (TIA, STEP 7, IEC)
    rank: int  # the order of the CLI's choices, and of recognition (the first whose `recognized_by` matches)
    help: str  # `generate --dialect`'s words for it
    template: str  # templates/<template>: the block's frame
    local_prefix: str  # '#' for TIA, nothing elsewhere
    type_names: dict
    body_indent: str
    array_type: str
    regions: str  # 'keyword': REGION ... END_REGION; 'comment': a comment line opens and closes a region
    array_initial: str  # 'brackets': := [a, b]; 'list': := a, b (classic STEP 7 SCL)
    suffix: str  # file name ending users expect
    eno: str  # the enable output: a system flag written under this name (TIA ENO, STEP 7 OK), or '' if declared
    retain: bool  # statics and outputs can be declared RETAIN (STEP 7: the instance DB is retentive as a whole)
    bench: Target
    bench_spelling: BenchSpelling
    rows_per_cycle: int  # calls of the block per PLC cycle in a test bench, by default
    recognized_by: str | None  # a regular expression a block source of this dialect matches; None: the rest
    functions: frozenset = PORTABLE_FUNCTIONS  # functions the dialect's compiler offers
    attributes: bool = True  # a Siemens header (VERSION, AUTHOR, NAME, FAMILY); IEC says them in a comment
    instance_db: str = ""  # generate --instance-db: the template (templates/) of an instance DB beside the block
    plcopen: bool = False  # generate --format plcopen wraps this dialect's block in PLCopen TC6 XML

    def recognizes(self, text: str) -> bool:
        return self.recognized_by is None or re.search(self.recognized_by, text) is not None
