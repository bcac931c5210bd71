"""Rotors written as scenes: a seeded generator of valid rotors drawn from physical ranges
(articulated, teetering, hingeless; rigid and beam blades; co-simulated stops and their continuous
twins), and the same writer for a rotor from a user's own numbers (scripts/cosim rotor)."""
