"""A test bench's source text -> AST: its data blocks and function blocks, with the three constructs a
block under test never has (a call of a block instance, an instance's output, a data block's item).
The grammar is the block's (verifier/reading/st.lark, start `sources`); the block parser refuses these."""
from __future__ import annotations

from thermoplc.verifier.reading import syntax as s
from thermoplc.verifier.reading.parser import (MAX_SOURCE_CHARACTERS, SUPPORTED_TYPES, StSyntaxError, Token, _at, _Section,
                                       _ToAst, parsed_from, v_args)


class _DataValue(tuple):
    """(array, index, value) of a data block's BEGIN section."""


class _BenchToAst(_ToAst):
    def sources(self, items):
        blocks = tuple(item for item in items if isinstance(item, s.Program))
        return s.Sources(blocks, tuple(item for item in items if isinstance(item, s.DataBlock)))

    def function_block(self, items):
        return self.start(items)

    @v_args(meta=True)
    def data_block(self, meta, items):
        layout = next(item for item in items[1:] if isinstance(item, list))
        values = tuple(tuple(item) for item in items[1:] if isinstance(item, _DataValue))
        return s.DataBlock(items[0], tuple(s.VarDecl(d.name, "static", d.type, None, d.pos) for d in layout),
                           values, _at(meta))

    def db_struct(self, items):
        return _Section([d for group in items for d in group], "")

    def db_layout(self, items):
        return items[0]

    def db_value(self, items):
        return _DataValue((str(items[0]), items[1], items[2]))

    @v_args(meta=True)
    def var_decl(self, meta, items):
        type_ref = next(i for i in items if isinstance(i, s.TypeRef))
        if type_ref.base in SUPPORTED_TYPES:
            return super().var_decl(meta, items)
        if len(items) > 2 and not isinstance(items[-1], (Token, s.TypeRef)):
            self._fail(_at(meta), "an instance of a block has no start value")
        names = [t for t in items if isinstance(t, Token) and t.type == "NAME"]  # an instance of a named block
        block = s.TypeRef("BLOCK", block=type_ref.block or type_ref.base)
        return [s.VarDecl(str(n), "", block, None, _at(n)) for n in names]

    def scalar_type(self, items):
        name = str(items[0])
        return s.TypeRef(name.upper()) if name.upper() in SUPPORTED_TYPES else s.TypeRef(name)

    def block_type(self, items):
        return s.TypeRef("BLOCK", block=str(items[0]).strip('"'))

    @v_args(meta=True)
    def fb_call(self, meta, items):
        return s.BlockCall(items[0].name, tuple(a for a in items[1:] if a is not None), _at(meta))

    @v_args(meta=True)
    def member(self, meta, items):
        return s.Member(items[0].name, str(items[1]), _at(meta))

    @v_args(meta=True)
    def global_item(self, meta, items):
        return s.GlobalItem(str(items[0]).strip('"'), str(items[1]), items[2], _at(meta))


def bench_transformer(source: str) -> _ToAst:
    """The transformer that reads a test bench's constructs (for a PLCopen bench's body)."""
    return _BenchToAst(source)


def parse_sources(text: str, source: str) -> s.Sources:
    """A test bench source (data blocks and function blocks, in any order), or a StSyntaxError naming the place."""
    if len(text) > MAX_SOURCE_CHARACTERS * 16:
        raise StSyntaxError(f"{source}: {len(text):,} characters; a test bench source is at most "
                            f"{MAX_SOURCE_CHARACTERS * 16:,} here")
    return parsed_from(text, source, "sources", _BenchToAst(source),
                       "file (missing END_FUNCTION_BLOCK or END_DATA_BLOCK?)")
