"""florence_locator.

FlorenceLocator (seed 3.8): room- and hotspot-level navigation API over move_base
(services florenceLocator/*).
"""
