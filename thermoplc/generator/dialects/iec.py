"""IEC 61131-3 Structured Text: CODESYS, TwinCAT, OpenPLC; PLCopen TC6 XML wraps it."""
from thermoplc.generator.dialects.definition import BenchSpelling, DialectDefinition, Target

DIALECT = DialectDefinition(
    name="iec", title="IEC", rank=2, help="IEC 61131-3 for CODESYS/TwinCAT/OpenPLC", template="iec.st.j2", local_prefix="",
    type_names={"REAL": "REAL", "BOOL": "BOOL", "INT": "INT"}, body_indent="    ",
    array_type="ARRAY[0..{last}] OF {type}", regions="comment", array_initial="brackets", suffix=".st", eno="",
    retain=True, attributes=False,
    bench=Target(65536, 262144, "constant arrays of at most 64 KiB each, 256 KiB in all"),
    bench_spelling=BenchSpelling("ARRAY[{lo}..{hi}] OF {type}", "(* {} *)", False,
                                 block_head=("FUNCTION_BLOCK {name}", "{title_comment}"), section_indent="",
                                 declaration_indent="    "),
    rows_per_cycle=50, recognized_by=None, plcopen=True)
