# The geometry core on planar domains, inputs, traces and frames.
# Geometry core (geom.c, trim.c) and the analytic backend.
pm_add_test(test_geom_analytic LABELS unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_geom_analytic.c)
pm_add_test(test_input LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_input.c)
pm_add_test(test_trace_frames LABELS unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_trace_frames.c)
pm_add_test(test_keyindex LABELS unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_keyindex.c)
pm_add_test(test_atomic_file LABELS unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_atomic_file.c)
