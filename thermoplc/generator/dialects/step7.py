"""Classic STEP 7 SCL: SINUMERIK 840D sl, S7-300/400."""
from thermoplc.generator.dialects.definition import BenchSpelling, DialectDefinition, Target

DIALECT = DialectDefinition(
    name="step7", title="STEP 7", rank=1, help="classic STEP 7 SCL (840D sl, S7-300)", template="step7.scl.j2", local_prefix="",
    type_names={"REAL": "REAL", "BOOL": "BOOL", "INT": "INT"}, body_indent="    ",
    array_type="ARRAY[0..{last}] OF {type}", regions="comment", array_initial="list", suffix=".scl", eno="OK",
    retain=False, functions=frozenset({"ABS", "SQRT"}),
    bench=Target(65536, 65536, "one DB of at most 64 KiB, the S7-300/400 limit (older S7-312/314 CPUs allow "
                               "16 KiB: give --calls)"),
    bench_spelling=BenchSpelling(
        "ARRAY[{lo}..{hi}] OF {type}", "// {}", True,
        block_head=('FUNCTION_BLOCK "{name}"', "TITLE = '{title}'", "VERSION : '0.1'", "AUTHOR : thermopl",
                    "NAME : {short}", "FAMILY : ThermTB"),
        section_indent="", declaration_indent="    ", untyped_constants=True,
        data_block_head=("TITLE = '{title}'", "VERSION : '0.1'", "AUTHOR : thermopl", "   STRUCT"),
        data_block_end="   END_STRUCT"),
    rows_per_cycle=10, recognized_by=r'(?im)^\s*FUNCTION_BLOCK\s+"', instance_db="step7_instance_db.scl.j2")
