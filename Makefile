# Two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   ?= .venv
BIN     = $(VENV)/bin
STAMP   = $(VENV)/.installed
# two cores: one BLAS thread per pytest worker
export OPENBLAS_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1

.PHONY: demo test test-serial check-fresh fuzz lint bench clean mpi-packages

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[dev]"
	if $(HAVE_MPI); then $(BIN)/python -m pip install --quiet -e ".[mpi]"; \
	  else echo "no mpiexec or libdmumps here: the mumps backend and its MPI tests are left out (make mpi-packages)"; fi
	touch $(STAMP)

# MPI and the parallel MUMPS (the mumps backend): Debian packages, installed by `make mpi-packages` (as root,
# or with sudo) and by .ci/run; then `make` adds mpi4py (the extra shellcontact[mpi])
MPI_PACKAGES = openmpi-bin libopenmpi-dev libmumps-dev libopenblas0-serial
HAVE_MPI = command -v mpiexec >/dev/null 2>&1 && /sbin/ldconfig -p | grep -q libdmumps

mpi-packages:
	@if $(HAVE_MPI); then echo "MPI and MUMPS are installed"; \
	elif ! command -v apt-get >/dev/null 2>&1; then echo "no apt-get: install an MPI and MUMPS by hand" >&2; exit 1; \
	else sudo=""; [ "$$(id -u)" = 0 ] || sudo="sudo -n"; \
	  $$sudo apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$sudo apt-get install -y -qq $(MPI_PACKAGES) \
	  && rm -f $(STAMP); fi

demo: $(STAMP)
	$(BIN)/shellcontact demo -o demo-out --force

test: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/python -m pytest -n 2 -q

# the suite without pytest-xdist (one process), as a check that no test depends on the worker split
test-serial: $(STAMP)
	$(BIN)/python -m pytest -q -p no:xdist

# what lands: a fresh clone of the committed HEAD, with ../shared beside it, runs `make test` from scratch
check-fresh:
	@tmp=$$(mktemp -d) && git clone -q "$(CURDIR)" "$$tmp/main" && ln -s "$(abspath ../shared)" "$$tmp/shared" \
	  && echo "fresh clone of $$(git rev-parse --short HEAD) in $$tmp/main" \
	  && $(MAKE) -C "$$tmp/main" test; rc=$$?; rm -rf "$$tmp"; exit $$rc

# 10 000 case files generated from the schema (tests/fuzz_cases.py), 1.5-3 minutes on 2 cores (76-187 s measured),
# and 300 each of output paths, --points files and --scheduler addresses (about 0.3 s per path or points file,
# measured on the fixed-seed subset: a few minutes more); `make test` runs a fixed-seed 300 cases (about 12 s)
# and 75 of each of the others (about 45 s)
fuzz: $(STAMP)
	$(BIN)/python -m pytest -n 2 -q tests/test_fuzz.py --hypothesis-profile=fuzz

bench: $(STAMP)
	$(BIN)/python -c "import osqp, clarabel" 2>/dev/null || $(BIN)/python -m pip install --quiet -e ".[bench]"
	$(BIN)/python benchmarks/run.py

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples

clean:
	rm -rf $(VENV) demo-out .pytest_cache .hypothesis
