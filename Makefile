# Visland: `make run` starts the ground station, `make test` installs everything and runs the suite.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
NODE_STAMP := frontend/node_modules/.installed-stamp
DIST := frontend/dist/index.html
FRONTEND_SRC := $(shell find frontend/src -type f 2>/dev/null) frontend/index.html frontend/vite.config.ts frontend/tsconfig.json

.PHONY: run test install frontend chromium lint types types-check format bench clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	# torch first and pinned: the CPU build on disk, never the multi-GB CUDA one.
	$(BIN)/pip install -q --disable-pip-version-check torch==2.13.0
	$(BIN)/pip install -q --disable-pip-version-check -e '.[dev]'
	touch $(STAMP)

$(NODE_STAMP): frontend/package.json frontend/package-lock.json
	cd frontend && npm ci --no-audit --no-fund --loglevel=error
	touch $(NODE_STAMP)

$(DIST): $(NODE_STAMP) $(FRONTEND_SRC)
	cd frontend && npm run build --silent

# The vision's compiled loops: compiled once here (seconds), then loaded from numba's cache.
install: $(STAMP) $(DIST)
	$(BIN)/python -m pipeline.warmup

frontend: $(DIST)

# The browser tests drive Debian's Chromium; never a downloaded browser.
chromium:
	@command -v chromium >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ]; then \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium >/dev/null; \
	  else echo "chromium is missing and this is not root: the browser tests will be skipped"; fi; }

run: install
	$(BIN)/python -m backend serve

test: install chromium lint
	cd frontend && npm test --silent
	$(BIN)/pytest

# Style, the import contracts (pyproject.toml [tool.importlinter]), the types, and the
# dashboard's protocol types up to date with the server's schemas.
lint: $(STAMP) $(NODE_STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/lint-imports --no-logo
	$(BIN)/mypy
	$(MAKE) --no-print-directory types-check

# The dashboard's TypeScript types, generated from the server's OpenAPI document
# (backend/api/schemas.py, backend/api/messages.py). Commit both files.
OPENAPI := frontend/openapi.json
API_TYPES := frontend/src/lib/api-types.ts
types: $(STAMP) $(NODE_STAMP)
	$(BIN)/python -m backend openapi $(OPENAPI)
	cd frontend && npx --no-install openapi-typescript openapi.json -o src/lib/api-types.ts --silent

# Fails when a schema changed and `make types` was not run (CI runs it via make lint).
types-check: $(STAMP) $(NODE_STAMP)
	@tmp=$$(mktemp -d) && trap 'rm -rf "$$tmp"' EXIT && \
	$(BIN)/python -m backend openapi "$$tmp/openapi.json" && \
	(cd frontend && npx --no-install openapi-typescript "$$tmp/openapi.json" -o "$$tmp/api-types.ts" --silent) && \
	cmp -s "$$tmp/openapi.json" $(OPENAPI) && cmp -s "$$tmp/api-types.ts" $(API_TYPES) || \
	{ echo "$(OPENAPI) or $(API_TYPES) is out of date with the server's schemas: run make types"; exit 1; }

format: $(STAMP)
	$(BIN)/ruff check --fix .
	$(BIN)/ruff format .

bench: install
	$(BIN)/python -m pipeline.bench --frames 200 --seed 0

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache .mypy_cache .import_linter_cache frontend/node_modules frontend/dist
