# Sizing fields and the neighbour grid (src/common/sizing/, src/common/sizing/grid.c).
pm_add_test(test_grid LABELS unit SOURCES test_grid.c)
pm_add_test(test_sizing LABELS unit SOURCES test_sizing.c)
