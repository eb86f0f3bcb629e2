"""Spatial decomposition for running on several MPI ranks (issue 32).

``comm``: the communicator (MPI ``COMM_WORLD`` or a one-rank ``SerialComm``) and the single
all-to-all exchange of numpy arrays; ``decomposition``: the domain cut into strips along one
axis, balanced for equal work; ``halo``: moving particles to their owners, ghost layers, and
global ids / row offsets. numpy and mpi4py only; everything works on one rank without MPI.
"""
