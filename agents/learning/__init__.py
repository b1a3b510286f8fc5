"""Learning agents: Double DQN, AlphaZero and PA-MCTS on networks trained on θ_0.

Importing this package (or anything here but the training modules ``ddqn`` and ``alphazero``)
does not import torch: trained networks are stored as arrays (:mod:`.artefacts`) and the agents
act with a numpy forward pass. Training needs the ``learn`` extra (torch).
"""
