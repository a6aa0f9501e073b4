"""TSAD: tree search with approaching direction (paper section IV): `plan` (theta* and the
sequential sub-searches), `sub_search` (one subgoal-conditioned MCTS), `config` (its settings)."""
