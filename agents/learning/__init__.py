"""Learning agents: Double DQN (and DDQN-WN), AlphaZero and PA-MCTS on networks trained on θ_0.

Importing this package does not import torch or numba. Trained networks are stored as arrays
(:mod:`.artefacts`) and the agents act with numpy forward passes. Double DQN trains and
DDQN-WN fine-tunes in NumPy (:mod:`.ddqn`); only AlphaZero's training (:mod:`.alphazero`)
imports torch (the ``learn`` extra), and compiled PUCT (:mod:`._puct_kernels`) imports numba
on first use.
"""
