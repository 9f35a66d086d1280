"""approach_me_map.

ApproachMe-Map (seed 3.10): navigates with move_base to a polite pose at safe_distance
from a detected user.
"""
