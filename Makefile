# One command: `make test` sets up .venv (finds or builds Python >= 3.12), then runs the tests.
VENV   := .venv
PY     := $(VENV)/bin/python
EXTRAS := fenicsx,viz,mesh,test,docs
LINTED := dd_contact tests demos benchmarks

.PHONY: venv test demo docs lint clean

venv: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml tools/libmpi_first.py
	tools/system_deps.sh
	$(PY) -c pass 2>/dev/null || { py="$$(tools/find_python.sh)" && "$$py" -m venv --clear $(VENV); }
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[$(EXTRAS)]'
	$(PY) tools/libmpi_first.py  # dolfinx/petsc4py importable before mpi4py
	touch $@

# Headless pictures: pyvista offscreen; EGL directly (skips VTK's failing X probe and its warning).
test demo: export PYVISTA_OFF_SCREEN := true
test demo: export VTK_DEFAULT_OPENGL_WINDOW ?= vtkEGLRenderWindow

# The mpi-marked tests run again on 2 ranks; pytest exit code 5 = none collected.
test: venv
	$(PY) -m pytest -q tests
	$(VENV)/bin/mpiexec -n 2 $(PY) -m pytest -q -m mpi tests || [ $$? -eq 5 ]

# The paper's two examples last: each prints where its pictures are and ends with its table.
demo: venv
	$(PY) demos/demo_tied_bar.py
	$(PY) demos/demo_one_mesh.py
	$(PY) demos/demo_hertz.py
	$(PY) demos/demo_parallelepiped.py
	$(PY) demos/demo_pin_joint.py

# The API reference from the docstrings (pdoc) in build/api; any pdoc warning fails.
docs: venv
	$(PY) docs/build_api.py build/api

# mypy checks the package (its files and settings: pyproject.toml's [tool.mypy]).
lint: venv
	$(VENV)/bin/ruff check $(LINTED)
	$(VENV)/bin/ruff format --check $(LINTED)
	$(VENV)/bin/mypy

clean:
	rm -rf $(VENV)
