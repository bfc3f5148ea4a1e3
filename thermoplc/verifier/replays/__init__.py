"""A block run over a recording and every output bit compared: against the model's float32 reference or a PLC
trace, streamed, with faults injected, across restarts, under stress at generate, between two blocks (diff),
and the reports these write."""
