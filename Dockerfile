# conformorph: one image for the API and the workers (see docker-compose.yml).

# the browser viewer, bundled by npm (three.js, esbuild) into service/static
FROM node:22-bookworm-slim AS viewer
WORKDIR /src
COPY package.json package-lock.json ./
RUN npm ci --no-audit --no-fund --loglevel=error
COPY viewer ./viewer
RUN npm run build:viewer

FROM python:3.11-slim-bookworm

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    OPENBLAS_NUM_THREADS=1 \
    OMP_NUM_THREADS=1 \
    CONFORMORPH_DATA_DIR=/data

WORKDIR /app
COPY pyproject.toml setup.py README.md ./
COPY conformorph ./conformorph
COPY conformorph_client ./conformorph_client
COPY geometry ./geometry
COPY pipelines ./pipelines
COPY worker ./worker
COPY service ./service
COPY cli ./cli
COPY --from=viewer /src/service/static ./service/static
# two distributions: the client (conformorph_client/pyproject.toml) and the server,
# whose packages install as conformorph.geometry, … with the viewer inside
RUN pip install ./conformorph_client ".[postgres,s3]" \
    && useradd --create-home --uid 10001 conformorph \
    && mkdir -p /data \
    && chown conformorph /data
USER conformorph
EXPOSE 8000
CMD ["uvicorn", "--factory", "conformorph.service.main:create_app", "--host", "0.0.0.0", "--port", "8000", "--timeout-keep-alive", "65"]
