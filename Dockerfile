# conformorph: one image for the API and the workers (see docker-compose.yml).
FROM python:3.11-slim-bookworm

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    OPENBLAS_NUM_THREADS=1 \
    OMP_NUM_THREADS=1 \
    CONFORMORPH_DATA_DIR=/data

WORKDIR /app
COPY pyproject.toml README.md ./
COPY geometry ./geometry
COPY pipelines ./pipelines
COPY worker ./worker
COPY service ./service
COPY cli ./cli
RUN pip install ".[postgres,s3]" \
    && useradd --create-home --uid 10001 conformorph \
    && mkdir -p /data \
    && chown conformorph /data
USER conformorph
EXPOSE 8000
CMD ["uvicorn", "--factory", "service.main:create_app", "--host", "0.0.0.0", "--port", "8000", "--timeout-keep-alive", "65"]
