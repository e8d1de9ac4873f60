"""Looking at results: tables rendered as text, markdown and HTML; the offline 3-D
recording; the report page and the README's generated blocks; progress lines."""
