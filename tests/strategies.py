"""Hypothesis strategies for random IR expression trees over a few REAL variables."""
from hypothesis import strategies as st

from thermoplc.generator.ir import BinOp, Call, Ref, Unary

VARIABLES = ("x1", "x2", "x3")
CONSTANTS = ("c_k1", "c_k2")


def real_exprs(max_leaves: int = 12):
    leaves = st.sampled_from([Ref(n) for n in VARIABLES + CONSTANTS])

    def extend(children):
        return st.one_of(
            st.builds(BinOp, st.sampled_from(["+", "-", "*", "/"]), children, children),
            st.builds(lambda e: Unary("-", e), children),
            st.builds(lambda e: Call("ABS", (e,)), children),
            st.builds(lambda e: Call("SQRT", (e,)), children),
            st.builds(lambda f, a, b: Call(f, (a, b)), st.sampled_from(["MIN", "MAX"]), children, children),
        )
    return st.recursive(leaves, extend, max_leaves=max_leaves)
