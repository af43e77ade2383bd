"""The science of each benchmark: the computations and report writers the tasks use."""
