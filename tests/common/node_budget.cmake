# The node count a size field needs, checked against a cap before a method grows
# (src/common/sizing/node_budget.c).
pm_add_test(test_node_budget LABELS unit backend
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_node_budget.c)
