# Tests of the mesh container, mesh files, quality measures and the validity checker.
pm_add_test(test_mesh LABELS unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_mesh.c)
pm_add_test(test_quality LABELS unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_quality.c)
pm_add_test(test_needles LABELS unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_needles.c)
pm_add_test(test_mesh_check LABELS unit backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_mesh_check.c)
pm_add_test(test_mesh_io LABELS unit backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_mesh_io.c)
pm_add_test(test_stats LABELS unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_stats.c)
target_link_libraries(test_stats PRIVATE cjson)
pm_add_test(test_mesh_check_cad LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_mesh_check_cad.c)
pm_add_test(test_mesh_read LABELS unit backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_mesh_read.c)
# Untagged meshes classified back onto the model's cells (classify.c).
pm_add_test(test_classify LABELS unit SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_classify.c)
