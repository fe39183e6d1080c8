# Visland ground station: the FastAPI/uvicorn server, the built dashboard and the 3D view.
# Build: docker build -t visland-gcs .   Run: see docker-compose.yml.

# --- the dashboard (TypeScript + Vite) -------------------------------------------------
FROM node:20-slim AS frontend
WORKDIR /src/frontend
COPY frontend/package.json frontend/package-lock.json ./
RUN npm ci
COPY frontend/ ./
RUN npm run build

# --- the server --------------------------------------------------------------------------
FROM python:3.11-slim
ENV PYTHONDONTWRITEBYTECODE=1 PYTHONUNBUFFERED=1 PIP_DISABLE_PIP_VERSION_CHECK=1
WORKDIR /app
# torch first and pinned, from the CPU index: never the multi-GB CUDA build.
RUN pip install --no-cache-dir torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu
COPY pyproject.toml README.md ./
COPY backend/ backend/
COPY pipeline/ pipeline/
# The stand-in vehicle and simulated camera: started when no vehicle or camera is named.
COPY sim/ sim/
RUN pip install --no-cache-dir .
COPY --from=frontend /src/frontend/dist frontend/dist
RUN useradd --create-home --uid 1000 visland && mkdir /data && chown visland /data
USER visland
# The vision's compiled loops (numba) are cached where this user may write: the
# installed package is root's.
ENV NUMBA_CACHE_DIR=/home/visland/.cache/numba
RUN python -m pipeline.warmup
VOLUME ["/data"]
# Inside the container the server must listen on all interfaces to be reachable;
# docker-compose.yml publishes the ports on the host's loopback only.
ENV VISLAND_HOST=0.0.0.0 VISLAND_DATA_DIR=/data
EXPOSE 8000
HEALTHCHECK --interval=10s --timeout=3s --start-period=20s \
    CMD python -c "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/api/health', timeout=2)"
CMD ["python", "-m", "backend", "serve"]
