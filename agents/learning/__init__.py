"""Learning agents: Double DQN (and DDQN-WN), AlphaZero and PA-MCTS on networks trained on θ_0.

Nothing here imports torch, and importing the package does not import numba. Trained networks
are stored as arrays (:mod:`.artefacts`) and the agents act with numpy forward passes. Double
DQN (:mod:`.ddqn`) and AlphaZero (:mod:`.alphazero`) train, and DDQN-WN fine-tunes, in NumPy
(:mod:`.mlp`); compiled PUCT (:mod:`._puct_kernels`) imports numba on first use.
"""
