"""florence_scenarios: the demo of the Florence system in florence_sim (make demo)."""
