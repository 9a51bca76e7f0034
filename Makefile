# spectrace: build into build/ (or build-san/ with SAN=1), tests with `make test`.
# `make render` and `make test` first install missing Debian packages
# (tools/install_deps.sh), then build and run. V=1 shows full command lines.

SAN ?= 0
ifeq ($(SAN),1)
BUILD ?= build-san
SANFLAGS := -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
else
BUILD ?= build
SANFLAGS :=
endif

CC ?= cc
CXX ?= g++
OPT ?= -O2
PKGS := OpenCL OpenImageIO OpenEXR tinygltf draco
# Recursive (=) so pkg-config runs when a recipe needs it, after install_deps.
PKG_CFLAGS = $(shell pkg-config --cflags $(PKGS) 2>/dev/null)
# The programs link all but OpenImageIO, which only libspectrace-oiio.so links
# (src/io/oiio_lib.h).
PKG_LIBS = $(shell pkg-config --libs $(filter-out OpenImageIO,$(PKGS)) 2>/dev/null)
OIIO_LIBS = $(shell pkg-config --libs OpenImageIO 2>/dev/null)
CPPFLAGS := -Isrc -Ikernels -I$(BUILD)/gen -DCL_TARGET_OPENCL_VERSION=120 -D_GNU_SOURCE
# Position-independent code, for build/libspectrace.so too; without semantic
# interposition the compiler inlines and calls as for the programs' PIE code.
PICFLAGS := -fPIC -fno-semantic-interposition
CFLAGS := -std=c11 $(OPT) -g -Wall -Wextra -MMD -MP $(PICFLAGS) $(SANFLAGS)
CXXFLAGS := -std=c++17 $(OPT) -g -Wall -Wextra -MMD -MP $(PICFLAGS) $(SANFLAGS) -I/usr/include/stb -I/usr/include/nlohmann
LDFLAGS := $(SANFLAGS)
LDLIBS = $(PKG_LIBS) -lmeshoptimizer -lm -lpthread -ldl -Wl,--dynamic-list=src/io/oiio_exports.list

ifeq ($(V),1)
Q :=
else
Q := @
endif

# The library: every source under src/ except the two programs' main files.
SRC_C := $(filter-out src/cli/main.c src/mpi/mpi_main.c,$(wildcard src/*/*.c))
# The OpenImageIO code is the shared library libspectrace-oiio.so, loaded when
# first needed (src/io/oiio_lib.h).
OIIO_SRCS := src/io/image_io.cpp src/io/texture_io.cpp
SRC_CXX := $(filter-out $(OIIO_SRCS),$(wildcard src/*/*.cpp))
OIIO_LIB := $(BUILD)/libspectrace-oiio.so
SHLIB := $(BUILD)/libspectrace.so
KERNEL_FILES := $(sort $(wildcard kernels/*/*.h kernels/*/*.cl))
GEN_C := $(BUILD)/gen/kernel_sources.c \
         $(if $(wildcard tools/rgb2spec/rgb2spec_opt.c),$(BUILD)/gen/rgb2spec_data.c)
LIB_OBJS := $(SRC_C:src/%.c=$(BUILD)/obj/%.o) $(SRC_CXX:src/%.cpp=$(BUILD)/obj/%.o) \
            $(GEN_C:$(BUILD)/gen/%.c=$(BUILD)/obj/gen/%.o)
LIB := $(BUILD)/libspectrace.a
PROG := $(BUILD)/spectrace
TEST_SRCS := $(wildcard tests/test_*.c)
TEST_BINS := $(TEST_SRCS:tests/%.c=$(BUILD)/tests/%)
# build/spectrace-mpi (`make mpi`): the same command line over MPI ranks
# (src/mpi/); only this program links Open MPI. Not built with sanitizers.
MPICC ?= mpicc
MPI_PROG := $(BUILD)/spectrace-mpi
MPI_LIBS = $(shell $(MPICC) --showme:link 2>/dev/null)
TOOL_BINS := $(patsubst tools/%.c,$(BUILD)/tools/%,$(wildcard tools/*.c))

.PHONY: all deps render test test-all test-san check tests bench mpi check-kernels clean denoise python
all: $(PROG) $(TEST_BINS) $(SHLIB)

# Every program loads it from beside itself or the folder above.
$(OIIO_LIB): $(OIIO_SRCS:src/%.cpp=$(BUILD)/obj/pic/%.o)
	@echo "LINK $@"
	$(Q)$(CXX) -shared $(LDFLAGS) -o $@ $^ $(OIIO_LIBS)

$(BUILD)/obj/pic/%.o: src/%.cpp
	@mkdir -p $(dir $@)
	@echo "CXX  $< (shared)"
	$(Q)$(CXX) $(CPPFLAGS) $(CXXFLAGS) -fPIC $(PKG_CFLAGS) -c -o $@ $<

$(BUILD)/obj/io/oiio_lib.o: CPPFLAGS += -DSPT_OIIO_BUILD_DIR='"$(abspath $(BUILD))"'

# The "mpi" group too: the tests run build/spectrace-mpi under mpirun. Then the
# other OpenCL implementations the tests run on (rusticl, Intel's CPU runtime in
# deps/) and Oclgrind; one that cannot be had is reported, not fatal.
deps:
	@tools/install_deps.sh mpi
	@tools/install_opencl.sh

mpi: deps
	@$(MAKE) --no-print-directory $(MPI_PROG)

# The main job: install what is missing, build, render the default scene.
render: deps
	@$(MAKE) --no-print-directory $(PROG)
	@tools/render_default.sh $(PROG)

# Open Image Denoise for --denoise (optional): the PyPI package pyoidn's
# libraries into deps/oidn/ (tools/install_oidn.sh), never system-wide.
denoise:
	@tools/install_oidn.sh

# The tests: install what is missing, build, run every test binary on PoCL and
# the device tests' quick form on the other implementations (tests/run_tests.sh,
# SPECTRACE_TEST_FORM), then the Python module's tests (tests/run_pytest.sh). test-all runs the device tests' full form on pocl-gpu and
# Intel's runtime too (CI). The tests of --denoise skip, saying why, where Open
# Image Denoise cannot be installed.
test test-all: deps
	@tools/install_oidn.sh --optional
	@$(MAKE) --no-print-directory tests
	@SPECTRACE_TEST_FORM=$(if $(filter test-all,$@),full,quick) tests/run_tests.sh $(BUILD)
	@tests/run_pytest.sh $(BUILD)
	@if [ $@ = test-all ] && tools/opencl_env.sh rusticl $(BUILD)/icd/rusticl >/dev/null 2>&1; then \
	  tests/run_pytest.sh $(BUILD) rusticl $(PYTEST_RUSTICL); fi

# test-all runs the Python module's tests on rusticl too, where installed: those
# that build only the program without options, which tests/run_tests.sh's
# rusticl subset builds (each other variant is a cold llvmpipe build of
# minutes there, tests/run_tests.sh), and render small: 13 of 21. Left out: the
# AOV and spectral renders and docs/api.md's examples (20 renders of 64x64 at 8
# spp; 128x128 at 16 spp; the frames example's turntable, whose dispersive glass
# merges photons: the -DSPT_MERGE program, another cold build), at llvmpipe's
# 600 paths a second.
PYTEST_RUSTICL := -k 'not (test_sweep_example or test_spectrum_example or test_c_example or \
  test_frames_example or test_render_arrays or test_render_function_and_layers or test_denoise or \
  test_checkpoint_and_resume)'

# A quick subset for the edit-compile-test loop (under a minute once built):
# the unit tests of the host code, the options, the loader and the kernels'
# headers on the device, without the long renders.
CHECK_TESTS := test_util test_options test_spectrum test_sampling test_rng test_gltf \
               test_gltf_wild test_image_out test_cl test_bsdf test_lights test_multidevice test_layering
check: $(PROG) $(CHECK_TESTS:%=$(BUILD)/tests/%)
	@SPECTRACE_TEST_IMPLS=pocl tests/run_tests.sh $(BUILD) $(CHECK_TESTS)

# The same tests built with AddressSanitizer and UndefinedBehaviorSanitizer, on
# PoCL only: the sanitizers check our host code, the same whichever
# implementation runs the kernels.
test-san: deps
	@$(MAKE) --no-print-directory SAN=1 tests
	@SPECTRACE_TEST_IMPLS=pocl tests/run_tests.sh build-san

# Small renders of the test scenes under Oclgrind (invalid accesses, data races,
# API misuse), on the GPU and the CPU code paths; fails on any report.
check-kernels: deps
	@$(MAKE) --no-print-directory $(PROG)
	@tools/check_kernels.sh $(BUILD)

tests: $(PROG) $(TEST_BINS) $(SHLIB) $(if $(filter 1,$(SAN)),,$(MPI_PROG))

bench: deps
	@$(MAKE) --no-print-directory OPT=-O3 $(PROG) $(MPI_PROG) $(TOOL_BINS)
	@tools/bench.sh $(BUILD)

# The library for other programs (src/api/spectrace.h, docs/api.md): the
# objects of libspectrace.a (PICFLAGS), exporting only spectrace_* and what
# libspectrace-oiio.so calls back (the version script). SHLIB is set above,
# beside OIIO_LIB, since the targets that need it are read first.
$(SHLIB): $(LIB_OBJS) src/api/spectrace.map | $(OIIO_LIB)
	@echo "LINK $@"
	$(Q)$(CXX) -shared $(LDFLAGS) -Wl,--version-script=src/api/spectrace.map \
	    -o $@ $(LIB_OBJS) $(PKG_LIBS) -lmeshoptimizer -lm -lpthread -ldl

# The Python module (src/python/spectrace) installed with pip into the virtual
# environment VENV (made when missing, with NumPy and pytest), finding the
# library through SPECTRACE_LIB or beside its sources (docs/api.md).
VENV ?= $(BUILD)/venv
# The copy that pip installs names the library's absolute path
# (spectrace/_library.py).
python: $(SHLIB)
	@test -x $(VENV)/bin/python || python3 -m venv --system-site-packages $(VENV)
	$(Q)$(VENV)/bin/python -c 'import numpy, pytest' 2>/dev/null || $(VENV)/bin/python -m pip install -q numpy pytest
	$(Q)rm -rf $(BUILD)/python && mkdir -p $(BUILD)/python && cp -r src/python/. $(BUILD)/python/
	$(Q)echo 'LIBRARY = "$(abspath $(SHLIB))"' > $(BUILD)/python/spectrace/_library.py
	$(Q)$(VENV)/bin/python -m pip install -q --force-reinstall --no-deps $(BUILD)/python
	@echo "installed spectrace into $(VENV) (library: $(abspath $(SHLIB)))"

$(PROG): $(BUILD)/obj/cli/main.o $(LIB) | $(OIIO_LIB)
	@echo "LINK $@"
	$(Q)$(CXX) $(LDFLAGS) -o $@ $^ $(LDLIBS)

$(MPI_PROG): $(BUILD)/obj/mpi/mpi_main.o $(BUILD)/obj/mpi/cli_main.o $(LIB) | $(OIIO_LIB)
	@echo "LINK $@"
	$(Q)$(CXX) $(LDFLAGS) -o $@ $^ $(LDLIBS) $(MPI_LIBS)

$(BUILD)/obj/mpi/mpi_main.o: src/mpi/mpi_main.c
	@mkdir -p $(dir $@)
	@echo "MPICC $<"
	$(Q)$(MPICC) $(CPPFLAGS) $(CFLAGS) $(PKG_CFLAGS) -c -o $@ $<

# src/cli/main.c once more with its main() renamed: spectrace-mpi's main calls it.
$(BUILD)/obj/mpi/cli_main.o: src/cli/main.c
	@mkdir -p $(dir $@)
	@echo "CC   $< (as spectrace_main)"
	$(Q)$(CC) $(CPPFLAGS) $(CFLAGS) -Dmain=spectrace_main -c -o $@ $<

# Objects compiled before PICFLAGS are built again once (this stamp is newer).
$(LIB_OBJS): $(BUILD)/obj/.pic
$(BUILD)/obj/.pic:
	@mkdir -p $(dir $@) && touch $@

$(LIB): $(LIB_OBJS)
	@echo "AR   $@"
	$(Q)rm -f $@ && ar rcs $@ $^

$(BUILD)/obj/%.o: src/%.c
	@mkdir -p $(dir $@)
	@echo "CC   $<"
	$(Q)$(CC) $(CPPFLAGS) $(CFLAGS) $(PKG_CFLAGS) -c -o $@ $<

$(BUILD)/obj/%.o: src/%.cpp
	@mkdir -p $(dir $@)
	@echo "CXX  $<"
	$(Q)$(CXX) $(CPPFLAGS) $(CXXFLAGS) $(PKG_CFLAGS) -c -o $@ $<

$(BUILD)/obj/gen/%.o: $(BUILD)/gen/%.c
	@mkdir -p $(dir $@)
	@echo "CC   $<"
	$(Q)$(CC) $(CPPFLAGS) $(CFLAGS) -c -o $@ $<

# Host tools (table generators, embedders, benchmarks) are plain C, built unsanitized
# and optimised, since some run during the build.
$(BUILD)/tools/%: tools/%.c $(LIB) | $(OIIO_LIB)
	@mkdir -p $(dir $@)
	@echo "CC   $<"
	$(Q)$(CC) $(CPPFLAGS) $(CFLAGS) $(PKG_CFLAGS) -o $@ $< $(LIB) $(LDLIBS) -lstdc++

# Kernel sources are embedded in the program so it runs from any folder.
$(BUILD)/gen/kernel_sources.c: $(KERNEL_FILES) tools/embed/embed_files.c
	@mkdir -p $(BUILD)/gen $(BUILD)/tools
	@echo "GEN  $@"
	$(Q)$(CC) -O1 -o $(BUILD)/tools/embed_files tools/embed/embed_files.c
	$(Q)$(BUILD)/tools/embed_files $(KERNEL_FILES) > $@.tmp && mv $@.tmp $@

# Jakob-Hanika 2019 sigmoid-polynomial coefficient table, fitted by our own C tool.
# Built without sanitizers and optimised: the fit is the slow part of a clean build.
$(BUILD)/gen/rgb2spec_data.c: tools/rgb2spec/rgb2spec_opt.c kernels/spectrum/cie_data.h
	@mkdir -p $(BUILD)/gen $(BUILD)/tools
	@echo "GEN  $@ (fitting the RGB-to-spectrum table)"
	$(Q)$(CC) -std=c11 -O2 -Ikernels -o $(BUILD)/tools/rgb2spec_opt tools/rgb2spec/rgb2spec_opt.c -lm -lpthread
	$(Q)$(BUILD)/tools/rgb2spec_opt $@.tmp && mv $@.tmp $@

$(BUILD)/tests/%: tests/%.c tests/test_util.h $(LIB) | $(OIIO_LIB)
	@mkdir -p $(dir $@)
	@echo "CC   $<"
	$(Q)$(CC) $(CPPFLAGS) -Itests $(CFLAGS) $(PKG_CFLAGS) -o $@ $< $(LIB) $(LDFLAGS) $(LDLIBS) -lcmocka -lstdc++

clean:
	rm -rf build build-san

-include $(shell find $(BUILD) -name '*.d' 2>/dev/null)
