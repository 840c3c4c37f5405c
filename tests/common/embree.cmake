# The Embree checks of the connection layer: closest points (closest_embree.c), the two-sided
# mesh-to-model distance (distance.c) and the self-intersection test (self_intersect.c).
pm_add_test(test_closest_embree LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_closest_embree.c)
pm_add_test(test_self_intersect LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_self_intersect.c)
# distance.c evaluates the size field (sizing.h), whose implementation is not in the tree yet:
# the test is registered as soon as it is (a program using pm_mesh_distance cannot link before).
file(GLOB PM_SIZING_SOURCES CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/src/common/sizing*.c ${CMAKE_SOURCE_DIR}/src/common/sizing*.cpp)
if(PM_SIZING_SOURCES)
  pm_add_test(test_distance LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_distance.c)
endif()
