# The Embree checks of the connection layer: closest points (closest_embree.c), the two-sided
# mesh-to-model distance (distance.c) and the self-intersection test (self_intersect.c).
pm_add_test(test_closest_embree LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_closest_embree.c)
pm_add_test(test_self_intersect LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_self_intersect.c)
pm_add_test(test_distance LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_distance.c)
