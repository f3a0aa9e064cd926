# plab_add_stage()
#
# Called from each stage folder's CMakeLists.txt (stages/NN-name: impl `student`, solutions/NN-name:
# `solution`, or kit/instructor/engine/NN-name: `engine`, the kit's instructor-only fast version of
# a stage, linked with plab::instructor). What the stage is comes from the folder's stage.json
# (docs/ARCHITECTURE.md lists its keys):
#   sources       the stage's sources (they define plab::make_stepper(), see stage.hpp)
#   kit_sources   the kit's sources compiled into every program linked with the stage, paths
#                 from the project's root (stage 08: kit/mpi/stage_entry.cpp, its entry points;
#                 its sources then write only plab::dist::step())
#   cuda_sources  a CPU stage's GPU path, compiled when nvcc is found (else the kit's stand-in
#                 kit/src/no_gpu_path.cpp: the stage runs on the CPU)
#   needs_gpu     a CUDA stage: skipped without nvcc
#   needs_openmp  skipped without OpenMP
#   needs_mpi     runs on several processes (mpirun): linked with the kit's plab::mpi (MPI's
#                 plumbing, kit/mpi), skipped without MPI; the runner calls its
#                 plab::stage_worker() first
#   model         "stepped" (model.md) or "exact" (stage 07: its own tests and golden files)
#   float_path, test_max_n, test_sizes, switches, simd: read by the runner and the tests
# Adds:
#   plab_stage_NN_IMPL   a library with the stage's code and its plab::stage_info()
#   plab-run-NN-IMPL     the runner (compiled once, kit/runner) linked with it: what
#                        `plab run --stage NN --impl IMPL` starts
# and records the stage's folder so that tests/ adds its tests.

# plab_stage_json(folder key out [default]): a value of folder/stage.json ("" or the default when
# absent); lists come back as CMake lists.
function(plab_stage_json folder key out)
  file(READ ${folder}/stage.json json)
  string(JSON type ERROR_VARIABLE missing TYPE "${json}" ${key})
  if(missing)
    set(${out} "${ARGN}" PARENT_SCOPE)
    return()
  endif()
  string(JSON value GET "${json}" ${key})
  if(type STREQUAL "ARRAY")
    string(JSON count LENGTH "${json}" ${key})
    set(value "")
    if(count GREATER 0)
      math(EXPR last "${count} - 1")
      foreach(k RANGE ${last})
        string(JSON item GET "${json}" ${key} ${k})
        list(APPEND value ${item})
      endforeach()
    endif()
  elseif(type STREQUAL "BOOLEAN")
    if(value)
      set(value TRUE)
    else()
      set(value FALSE)
    endif()
  endif()
  set(${out} "${value}" PARENT_SCOPE)
endfunction()

# C++ text for a list of strings: {"a", "b"}.
function(plab_cpp_strings out)
  set(text "")
  foreach(item IN LISTS ARGN)
    if(text)
      string(APPEND text ", ")
    endif()
    string(APPEND text "\"${item}\"")
  endforeach()
  set(${out} "{${text}}" PARENT_SCOPE)
endfunction()

function(plab_add_stage)
  set(dir ${CMAKE_CURRENT_SOURCE_DIR})
  get_filename_component(folder ${dir} NAME)
  get_filename_component(tree ${dir} DIRECTORY)
  get_filename_component(tree ${tree} NAME)
  string(SUBSTRING ${folder} 0 2 id)
  string(SUBSTRING ${folder} 3 -1 name)
  if(tree STREQUAL "solutions")
    set(impl solution)
  elseif(tree STREQUAL "engine")
    set(impl engine)
  else()
    set(impl student)
  endif()
  plab_stage_json(${dir} sources sources)
  plab_stage_json(${dir} cuda_sources cuda_sources)
  plab_stage_json(${dir} kit_sources kit_sources)
  plab_stage_json(${dir} needs_gpu needs_gpu FALSE)
  plab_stage_json(${dir} needs_openmp needs_openmp FALSE)
  plab_stage_json(${dir} model model stepped)
  plab_stage_json(${dir} float_path float_path FALSE)
  plab_stage_json(${dir} test_max_n test_max_n 1000000000)
  plab_stage_json(${dir} test_sizes test_sizes small medium large)
  plab_stage_json(${dir} switches switches)
  plab_stage_json(${dir} simd simd)
  plab_stage_json(${dir} needs_mpi needs_mpi FALSE)
  if(needs_gpu AND NOT PLAB_HAVE_CUDA)
    message(STATUS "stage ${id} (${impl}): skipped, no CUDA compiler")
    return()
  endif()
  if(needs_mpi AND NOT MPI_CXX_FOUND)
    message(WARNING "MPI not found (Debian: openmpi-bin libopenmpi-dev): stage ${id} (${impl}) is "
                    "skipped")
    return()
  endif()
  if(needs_openmp AND NOT OpenMP_CXX_FOUND)
    message(WARNING "OpenMP not found: stage ${id} (${impl}) is skipped")
    return()
  endif()

  # What the stage is, for the runner and the tests (plab::stage_info()).
  set(gpu_path FALSE)
  if(cuda_sources AND PLAB_HAVE_CUDA)
    set(gpu_path TRUE)
  endif()
  set(worker_cpp nullptr)
  set(sanitizer_cpp "")
  if(needs_mpi)
    set(worker_cpp "&plab::stage_worker")
    if(CMAKE_CXX_FLAGS MATCHES "sanitize=address")
      # OpenMPI never frees what MPI_Init allocates, in plugins it unloads before LeakSanitizer
      # looks (frames of an unknown module, which no suppression can name): no leak check in this
      # stage's programs; every other ASan and UBSan check stays on.
      set(sanitizer_cpp "extern \"C\" const char* __lsan_default_options() { return \"detect_leaks=0\"; }")
    endif()
  endif()
  foreach(flag IN ITEMS needs_gpu gpu_path float_path needs_mpi needs_openmp)
    if(${flag})
      set(${flag}_cpp true)
    else()
      set(${flag}_cpp false)
    endif()
  endforeach()
  plab_cpp_strings(test_sizes_cpp ${test_sizes})
  plab_cpp_strings(switches_cpp ${switches})
  plab_cpp_strings(simd_cpp ${simd})
  set(info_cpp ${CMAKE_CURRENT_BINARY_DIR}/stage_info.cpp)
  configure_file(${PROJECT_SOURCE_DIR}/cmake/stage_info.cpp.in ${info_cpp} @ONLY)

  set(lib plab_stage_${id}_${impl})
  add_library(${lib} STATIC ${sources} ${info_cpp})
  # The kit's sources of the stage go into every program linked with it, as objects of its own
  # (INTERFACE), not into the stage's archive: the linker then always takes them, and a stage
  # that defines their functions again (stage 08's make_stepper()) fails to link rather than
  # having its own definition picked from the archive instead of the kit's.
  foreach(given IN LISTS kit_sources)
    target_sources(${lib} INTERFACE ${PROJECT_SOURCE_DIR}/${given})
  endforeach()
  target_link_libraries(${lib} PUBLIC plab::kit)
  if(impl STREQUAL "engine")
    target_link_libraries(${lib} PUBLIC plab::instructor)  # the answers' headers it may use
  endif()
  math(EXPR number "${id}")  # "04" -> 4 (a preprocessor number, not octal)
  # PLAB_STAGE_NUMBER: kit headers hide from a stage what its own exercise writes (stage 04: the
  # device arrays' copies and DeviceParticles, its exercise 1).
  target_compile_definitions(${lib} PRIVATE PLAB_STAGE_ID="${id}" PLAB_STAGE_NUMBER=${number})
  # No NVTX in a stage's CUDA code: CUB's ranges start NVTX's loader, which calls dlopen and dlsym
  # from the stage's own objects. Without it a stage's objects call neither, and the grader
  # refuses them in CUDA objects as in C++ ones (a student's trial reached popen through dlsym in
  # a host function of step.cu).
  target_compile_definitions(${lib} PRIVATE
                             $<$<COMPILE_LANGUAGE:CUDA>:CCCL_DISABLE_NVTX NVTX_DISABLE>)
  if(impl STREQUAL "solution" AND IS_DIRECTORY ${PROJECT_SOURCE_DIR}/stages/${folder})
    # A given file that the exercise leaves as it is lives once, in the starting point
    # (stages/NN-name): a solution folder holds only the files the student changes, and finds the
    # others there (its own folder is searched first).
    target_include_directories(${lib} PRIVATE ${PROJECT_SOURCE_DIR}/stages/${folder})
  endif()
  if(needs_gpu)
    target_link_libraries(${lib} PUBLIC plab::cuda)
  elseif(gpu_path)
    target_sources(${lib} PRIVATE ${cuda_sources})
    target_link_libraries(${lib} PUBLIC plab::cuda)
  elseif(cuda_sources)
    target_sources(${lib} PRIVATE ${PROJECT_SOURCE_DIR}/kit/src/no_gpu_path.cpp)
  endif()
  if(needs_mpi)
    target_link_libraries(${lib} PUBLIC plab::mpi)  # kit/mpi: the slabs, exchanges and driver
  endif()

  set(program plab-run-${id}-${impl})
  add_executable(${program})
  target_link_libraries(${program} PRIVATE plab_runner ${lib})

  set_property(GLOBAL APPEND PROPERTY PLAB_STAGE_DIRS ${dir})
endfunction()
