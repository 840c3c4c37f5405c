# The C++ adapters behind plain-C headers: CGAL's constrained Delaunay triangulation and TetGen.
pm_add_test(test_cdt_cgal LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_cdt_cgal.c)
pm_add_test(test_tet_tetgen LABELS backend SOURCES ${CMAKE_CURRENT_LIST_DIR}/test_tet_tetgen.c)
# libgmsh exports a TetGen of its own (tetgenmesh::*, tetgenbehavior::parse_commandline, with a
# different layout); the dynamic linker binds libtet's internal calls to whichever library comes
# first in the program's DT_NEEDED list. libtet must come first, whatever order the library's
# link interface gives: list it before every object and library of this test.
target_link_options(test_tet_tetgen BEFORE PRIVATE "LINKER:--no-as-needed" ${TETGEN_LIBRARY})
