# Sizing fields and the neighbour grid (src/common/sizing/, src/common/sizing/grid.c).
pm_add_test(test_grid LABELS unit SOURCES test_grid.c)
pm_add_test(test_sizing LABELS unit SOURCES test_sizing.c)

# The feature size across planar strips set against the feature floor: a width above the floor
# asks for itself, one between half the floor and the floor asks for the floor, a narrower none.
pm_add_test(test_sizing_features LABELS unit
  SOURCES test_sizing_features.c)
