"""NS-Gym 1.0.12's public API over the ns_pz core: switch by changing the package name."""
