# The CAD backend (geom_cad*.c): gmsh/OpenCASCADE models and the built-in solid cases.
pm_add_test(test_geom_cad LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_geom_cad.c)
pm_add_test(test_geom_cad_eval LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_geom_cad_eval.c)
pm_add_test(test_geom_cad_loops LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_geom_cad_loops.c)
