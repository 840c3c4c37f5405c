# The C++ adapters behind plain-C headers: CGAL's constrained Delaunay triangulation and TetGen.
# (TetGen's test relies on the library's link interface listing libtet before libgmsh; the
# adapter refuses to run TetGen otherwise, see src/common/backends/tet_tetgen.cpp.)
pm_add_test(test_cdt_cgal LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_cdt_cgal.c)
pm_add_test(test_tet_tetgen LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_tet_tetgen.c)
