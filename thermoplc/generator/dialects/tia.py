"""TIA Portal SCL: S7-1500 and SINUMERIK ONE."""
from thermoplc.generator.dialects.definition import BenchSpelling, DialectDefinition, Target

DIALECT = DialectDefinition(
    name="tia", title="TIA", rank=0, help="S7-1500/SINUMERIK ONE (TIA Portal)", template="tia.scl.j2", local_prefix="#",
    type_names={"REAL": "Real", "BOOL": "Bool", "INT": "Int"}, body_indent="\t", array_type="Array[0..{last}] of {type}",
    regions="keyword", array_initial="brackets", suffix=".scl", eno="ENO", retain=True,
    bench=Target(65536, 262144, "DBs of at most 64 KiB, 256 KiB in all: a quarter of the smallest S7-1500's data "
                                "memory (an S7-1200 holds less: give --calls)"),
    bench_spelling=BenchSpelling(
        "Array[{lo}..{hi}] of {type}", "// {}", True,
        block_head=('FUNCTION_BLOCK "{name}"', "TITLE = {title}", "{{ S7_Optimized_Access := 'TRUE' }}",
                    "AUTHOR : thermopl", "FAMILY : ThermTB", "NAME : {short}", "VERSION : 0.1"),
        section_indent="   ", declaration_indent="      ",
        data_block_head=("TITLE = {title}", "{{ S7_Optimized_Access := 'TRUE' }}", "VERSION : 0.1", "   VAR"),
        data_block_end="   END_VAR"),
    rows_per_cycle=50, recognized_by="S7_Optimized_Access")
