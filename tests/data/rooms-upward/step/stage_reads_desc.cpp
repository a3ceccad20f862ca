// A step/ file that reads a description while stepping: scripts/check-rooms.sh must refuse it.
double relaxation(const haustra::SolverDesc& solver) { return solver.relaxation; }
