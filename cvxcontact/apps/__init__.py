"""Applications: the command line, sweeps, the demo and the verification studies."""
