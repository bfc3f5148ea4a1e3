"""A block's text read into the AST: the grammar, the parser, the one-reading rule, block files (ST or PLCopen
XML) and test bench sources. Imports nothing else of the verifier."""
