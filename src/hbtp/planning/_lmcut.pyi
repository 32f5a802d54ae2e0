# LM-cut's rounds in C (src/hbtp/planning/_lmcut.c, where the arguments are described): eight int32
# arrays of compressed rows (preconditions, add effects, users, achievers), the state's h_max,
# precondition values, choices and costs (array.array, changed in place), and the atom to cut for;
# returns the cost the round adds to the estimate.
def cut(*arrays_then_top: object) -> float: ...
