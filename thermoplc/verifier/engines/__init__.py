"""Running a parsed block in binary32: the interpreter (the reference semantics), the native C engine and its
cache, what an ST operation means for both, values by declared type, and which engine a replay uses."""
