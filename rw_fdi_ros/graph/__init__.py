"""The graph's contract and plumbing, apart from the node programs (``nodes/``): topic names and who reads
what (topics), message conversions (convert), the node runtime (runtime, parameters, gate, sync, timing),
the observer node's shared class (observer_node), the plant's messages (plant_report) and the console-script
entry points (entry). Tools import this room, never ``nodes/``."""
