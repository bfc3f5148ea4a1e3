"""The proof, independent of the generator: read a block's ST, run it in binary32, replay recorded data through it.

One subpackage per job, each importing only those listed before it: `reading` (ST or PLCopen XML into the AST),
`engines` (the interpreter, the native C engine and what an operation means for both), `replays` (a block run
over a recording against its model or a PLC trace: verify, faults, restarts, stress, diff, test benches),
`fleets` (many pairs at once, in processes or on a Dask cluster)."""
